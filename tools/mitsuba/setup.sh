#!/usr/bin/env bash
# Creates tools/mitsuba/.venv with Mitsuba 3 (the `mitsuba` wheel from PyPI) so that
# `brume mitsuba` and tests/external/mitsuba_compare.rs can run. Idempotent: an existing venv that
# imports mitsuba is kept. The fast variant, `llvm_ad_rgb`, JIT-compiles with LLVM and needs
# a libLLVM >= 16 at run time, which Debian 12 has as `libllvm19`; without it Mitsuba still
# runs as `scalar_rgb` (one ray at a time, much slower), and `brume mitsuba` says so.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$here/.venv"
start=$(date +%s)

# The LLVM runtime for Dr.Jit's LLVM back end (only the shared library, ~100 MB).
if ! dpkg-query -W -f='${Status}' libllvm19 2>/dev/null | grep -q "install ok installed"; then
    if [ "$(id -u)" -eq 0 ]; then
        echo "mitsuba: installing libllvm19 (Dr.Jit's LLVM back end)"
        apt-get update -qq || true
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libllvm19 \
            || echo "mitsuba: could not install libllvm19; the scalar_rgb variant will be used" >&2
    else
        echo "mitsuba: libllvm19 missing and not root; the scalar_rgb variant will be used" >&2
    fi
fi

if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import mitsuba" 2>/dev/null; then
    echo "mitsuba: already installed in $venv"
else
    python3 -m venv "$venv"
    # No pip cache, and no half venv left behind when the install fails (see tools/cycles/ci.sh).
    if ! "$venv/bin/pip" install --quiet --disable-pip-version-check --no-cache-dir "mitsuba==3.*"; then
        rm -rf "$venv"
        echo "mitsuba: pip install mitsuba failed; tests/external/mitsuba_compare.rs will skip" >&2
        exit 1
    fi
fi
"$venv/bin/python" -c "import mitsuba; print('mitsuba:', mitsuba.__version__)"
if "$venv/bin/python" -c "import mitsuba as mi; mi.set_variant('llvm_ad_rgb')" 2>/dev/null; then
    echo "mitsuba: variant llvm_ad_rgb works"
else
    echo "mitsuba: llvm_ad_rgb unavailable (no usable libLLVM); brume mitsuba will use scalar_rgb" >&2
fi
echo "mitsuba: done in $(( $(date +%s) - start )) s, venv $(du -sh "$venv" | cut -f1)"
