#!/usr/bin/env bash
# Prepares the peer race (make bench-peers): Debian's libllvm19 for Mitsuba's
# llvm_* variants (LLVM 15/16 abort with "Cannot select: fminimum"), python3-venv,
# and a venv with Mitsuba 3 and numpy from PyPI. Idempotent: does nothing when
# everything is in place. Prints the libLLVM path for DRJIT_LIBLLVM_PATH last.
#
# usage: bench/peers/setup.sh VENV_DIR MITSUBA_SPEC NUMPY_SPEC
set -euo pipefail
venv=${1:-.venv-peers}
mitsuba_spec=${2:-mitsuba==3.9.1}
numpy_spec=${3:-numpy>=1.24,<3}

find_llvm() {
  local f
  for f in "${DRJIT_LIBLLVM_PATH:-}" /usr/lib/*/libLLVM-19.so /usr/lib/*/libLLVM.so.19* /usr/lib/llvm-19/lib/libLLVM*.so*; do
    [ -n "$f" ] && [ -e "$f" ] && { echo "$f"; return 0; }
  done
  return 1
}

missing=""
find_llvm >/dev/null || missing="libllvm19"
if ! command -v python3 >/dev/null 2>&1; then
  missing="$missing python3 python3-venv"
elif ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
  missing="$missing python3-venv"
fi
if [ -n "$missing" ]; then
  echo "bench-peers: installing missing system packages:$missing" >&2
  if [ "$(id -u)" = 0 ]; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update >&2 && apt-get install -y $missing >&2
  elif command -v sudo >/dev/null 2>&1; then
    sudo apt-get update >&2 && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y $missing >&2
  else
    echo "bench-peers: not root and no sudo. Run as root: apt-get update && apt-get install -y$missing" >&2
    exit 1
  fi
fi

want_version=""
case "$mitsuba_spec" in mitsuba==*) want_version=${mitsuba_spec#mitsuba==} ;; esac
have_version=$("$venv/bin/python" -c 'import importlib.metadata as m; print(m.version("mitsuba"))' 2>/dev/null || true)
if [ -z "$have_version" ] || { [ -n "$want_version" ] && [ "$have_version" != "$want_version" ]; } \
   || ! "$venv/bin/python" -c 'import numpy' >/dev/null 2>&1; then
  echo "bench-peers: creating $venv with $mitsuba_spec and $numpy_spec" >&2
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "$mitsuba_spec" "$numpy_spec" >&2
fi
find_llvm
