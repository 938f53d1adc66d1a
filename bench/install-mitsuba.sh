#!/usr/bin/env bash
# Installs what bench/bench_cornell.py needs to compare caustica with Mitsuba 3:
#   - the `mitsuba` wheel (pinned) into the project's virtual environment (.venv), and
#   - Debian's libllvm19, which Dr.Jit loads at run time for the `llvm_ad_rgb` variant.
# Idempotent: does nothing that is already done. Run from anywhere:  bash bench/install-mitsuba.sh
# Afterwards run the benchmark with the path it prints, e.g.
#   DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so .venv/bin/python bench/bench_cornell.py
# (bench_cornell.py also looks for libLLVM-19 itself when DRJIT_LIBLLVM_PATH is unset.)
# Without LLVM the benchmark falls back to Mitsuba's `scalar_rgb` variant and says so.
set -euo pipefail

MITSUBA_VERSION="${MITSUBA_VERSION:-3.9.1}"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$ROOT/.venv/bin/python"

if [ ! -x "$PY" ]; then
  echo "install-mitsuba: $PY not found; run 'make build' first" >&2
  exit 1
fi

have="$("$PY" -c 'import importlib.metadata as m; print(m.version("mitsuba"))' 2>/dev/null || true)"
if [ "$have" = "$MITSUBA_VERSION" ]; then
  echo "install-mitsuba: mitsuba $have already installed"
else
  echo "install-mitsuba: installing mitsuba==$MITSUBA_VERSION (found: ${have:-none})"
  "$PY" -m pip install -q "mitsuba==$MITSUBA_VERSION"
fi

find_llvm() {
  ls /usr/lib/x86_64-linux-gnu/libLLVM-19.so* /usr/lib/x86_64-linux-gnu/libLLVM.so.19* /usr/lib/llvm-19/lib/libLLVM*.so* 2>/dev/null | head -n1 || true
}

llvm="$(find_llvm)"
if [ -z "$llvm" ]; then
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    echo "install-mitsuba: installing libllvm19 (Debian)"
    if ! apt-get install -y -qq libllvm19 >/dev/null 2>&1; then
      apt-get update -qq >/dev/null 2>&1 || true
      apt-get install -y -qq libllvm19 >/dev/null 2>&1 || true
    fi
    llvm="$(find_llvm)"
  fi
fi

if [ -n "$llvm" ]; then
  echo "install-mitsuba: LLVM for Dr.Jit: $llvm"
  echo "DRJIT_LIBLLVM_PATH=$llvm"
else
  echo "install-mitsuba: libllvm19 not available; bench_cornell.py will use Mitsuba's scalar_rgb variant" >&2
fi
