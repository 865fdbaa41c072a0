#!/usr/bin/env bash
# Opt-in: installs llama-cpp-python's OpenAI-compatible server (PyPI llama-cpp-python[server]
# 0.3.36, which builds llama.cpp from source: about 30 minutes on 2 cores) into the project's
# Python ($OPENGRAPH_VENV, default ~/.cache/opengraph/venv, made by scripts/setup.sh), for
# api/tests/llm_server.rs (run it with OPENGRAPH_LLAMA_SERVER=1). Idempotent.
#
# llama.cpp is built for AVX2/AVX-512 without -march=native: a native build also compiles its
# AMX kernels, and on the machines this was tried on (Xeon with AMX flags, in a VM) every
# batched decode then died with SIGSEGV in llama_decode; one token at a time worked.
set -euo pipefail
VENV="${OPENGRAPH_VENV:-$HOME/.cache/opengraph/venv}"
PY="$VENV/bin/python"
MODEL="${OPENGRAPH_MODELS:-$HOME/.cache/opengraph/models}/qwen2.5-coder-0.5b-instruct-q4_k_m.gguf"
[ -x "$PY" ] || { echo "no $PY: run scripts/setup.sh first" >&2; exit 2; }

# a working install decodes a batch of several tokens (the native build's crash)
smoke() {
    [ -f "$MODEL" ] || return 0
    timeout 300 "$PY" -c "
from llama_cpp import Llama
l = Llama(model_path='$MODEL', n_ctx=512, verbose=False)
l.create_completion('The colour of the sky on a clear day is', max_tokens=3, temperature=0)
" >/dev/null 2>&1
}

if "$PY" -c "import llama_cpp.server" 2>/dev/null && smoke; then
    echo "llama-cpp-python's server is installed in $VENV"
    exit 0
fi
echo "building llama-cpp-python 0.3.36 from source (about 30 minutes on 2 cores)..."
CMAKE_ARGS="-DGGML_NATIVE=OFF -DGGML_AVX=ON -DGGML_AVX2=ON -DGGML_FMA=ON -DGGML_F16C=ON -DGGML_AVX512=ON" \
CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" \
    "$VENV/bin/pip" install --force-reinstall --no-cache-dir 'llama-cpp-python[server]==0.3.36'
smoke || { echo "llama-cpp-python installed but a batched decode fails on this machine" >&2; exit 1; }
echo "llama-cpp-python's server is installed in $VENV; run: OPENGRAPH_LLAMA_SERVER=1 cargo test -p api --test llm_server"
