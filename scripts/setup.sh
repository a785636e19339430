#!/usr/bin/env bash
# One-time, idempotent set-up on Debian/Ubuntu: system library for open3d, .venv with
# Python 3.11, the bpy wheel (Blender 4.5 LTS as a module) and the Python packages.
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
# the library cache read once: `ldconfig -p | grep -q` under pipefail fails at random (grep
# quits at the first match, ldconfig gets SIGPIPE) and reinstalled present libraries
libs=$(ldconfig -p 2>/dev/null || true)
has() { grep -qF "$1" <<< "$libs"; }
if ! has 'libusb-1.0.so.0'; then need_apt+=(libusb-1.0-0); fi
# bpy (Blender as a module) links to a few X/GL libraries that minimal images lack
for lib in libX11.so.6:libx11-6 libXrender.so.1:libxrender1 libXxf86vm.so.1:libxxf86vm1 \
           libXfixes.so.3:libxfixes3 libXi.so.6:libxi6 libxkbcommon.so.0:libxkbcommon0 \
           libSM.so.6:libsm6 libgomp.so.1:libgomp1 libGL.so.1:libgl1 libEGL.so.1:libegl1; do
  so=${lib%%:*}; pkg=${lib##*:}
  has "$so" || need_apt+=("$pkg")
done
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing system libraries: ${need_apt[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

PY=${PYTHON:-}
if [ -z "$PY" ]; then
  for c in python3.11 python3; do
    if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then PY=$c; break; fi
  done
fi
if [ -z "$PY" ]; then
  echo "setup: Python 3.11 is required (the bpy wheel is built for it); set PYTHON=/path/to/python3.11" >&2
  exit 1
fi
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $PY"
  "$PY" -m venv .venv
fi
stamp=.venv/.installed
want=$(cat requirements.txt pyproject.toml | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "setup: installing Python packages (first time: a few minutes)"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -r requirements.txt
  .venv/bin/python -m pip install -q --no-deps --no-build-isolation -e . 2>/dev/null \
    || .venv/bin/python -m pip install -q --no-deps -e .
  echo "$want" > "$stamp"
fi
# byte-compile the engine and the add-on, as an installed package is: an editable checkout
# run under PYTHONDONTWRITEBYTECODE (set in many containers) would otherwise compile its 80
# modules from source at every start (0.2 s of each convert); stale files are redone
.venv/bin/python -m compileall -q -j 0 engine blender_indoor_addon >/dev/null
