#!/usr/bin/env bash
# Run the test suite headless inside Blender: a real `blender` >= 4.2 from PATH when there
# is one, else Blender 4.5 as a Python module (the bpy wheel in .venv).
set -euo pipefail
cd "$(dirname "$0")/.."
if command -v blender >/dev/null 2>&1; then
  ver=$(blender --version 2>/dev/null | sed -n 's/^Blender \([0-9]*\.[0-9]*\).*/\1/p' | head -1)
  if [ -n "$ver" ] && [ "$(printf '%s\n4.2\n' "$ver" | sort -V | head -1)" = "4.2" ]; then
    echo "tests: using Blender $ver from PATH"
    exec blender -b --factory-startup --python-exit-code 1 --python tests/run_tests.py -- "$@"
  fi
fi
echo "tests: using the bpy module in .venv"
exec .venv/bin/python tests/run_tests.py "$@"
