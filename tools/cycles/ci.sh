#!/usr/bin/env bash
# Creates tools/cycles/.venv (Python 3.11) with Blender as a module (bpy 5.0.1 from PyPI) so that
# `brume cycles` and tests/external/cycles_compare.rs can run Cycles. Idempotent: an existing venv that
# imports bpy is kept.
#
# About a minute (download and install) and 1 GB on disk for the venv (the bpy 5.0.1 wheel plus
# numpy, requests, zstandard, cython); the comparison test itself takes well under a minute.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$here/.venv"
if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import bpy" 2>/dev/null; then
    echo "cycles: bpy already installed in $venv"
    exit 0
fi
py="${PYTHON311:-}"
if [ -z "$py" ]; then
    for c in python3.11 python3; do
        if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
            py="$c"
            break
        fi
    done
fi
if [ -z "$py" ]; then
    echo "cycles: bpy 5.0.1 needs Python 3.11, none found; tests/external/cycles_compare.rs will skip" >&2
    exit 1
fi
start=$(date +%s)
"$py" -m venv "$venv"
# No pip cache (the wheel would be kept twice), and a failed install (a full disk, a network
# error) leaves no half venv behind to take the space or pass for an installed one.
if ! "$venv/bin/pip" install --quiet --disable-pip-version-check --no-cache-dir bpy==5.0.1; then
    rm -rf "$venv"
    echo "cycles: pip install bpy==5.0.1 failed; tests/external/cycles_compare.rs will skip" >&2
    exit 1
fi
"$venv/bin/python" -c "import bpy; print('cycles: bpy', bpy.app.version_string)"
echo "cycles: installed in $(( $(date +%s) - start )) s, $(du -sh "$venv" | cut -f1)"
