#!/usr/bin/env bash
# Packs what a bare GPU machine with no network needs to run Brume's GPU checks (check.sh):
# the stripped release binary, the GPU test binaries, OpenVDB's shared libraries and Debian's
# Vulkan loader and GL dispatch libraries (the NVIDIA driver's ICD needs libglvnd). Run after
# `cargo build --release --tests`, in the repository root; writes OUT_DIR (default .gpu_check,
# which .git/info/exclude should list), about 30 MB.
set -euo pipefail
out="${OUT_DIR:-.gpu_check}"
rm -rf "$out" && mkdir -p "$out"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/b/lib" "$work/t"
cp target/release/brume "$work/b/brume" && strip "$work/b/brume"
# Every shared library the binary needs beyond glibc and libstdc++ (present on any image).
ldd target/release/brume | awk '$3 ~ /^\// {print $3}' \
    | grep -vE '/(libc|libm|libgcc_s|libstdc\+\+|ld-linux)[.-]' \
    | while read -r l; do cp -L "$l" "$work/b/lib/"; done
for t in gpu_dda gpu_distance gpu_transmittance gpu_render gpu_media_overlap; do
    f="$(ls -t target/release/deps/ | grep -E "^$t-[0-9a-f]+$" | head -1)"
    cp "target/release/deps/$f" "$work/t/$t" && strip "$work/t/$t"
done
tar czf "$out/brume.tgz" -C "$work/b" .
tar czf "$out/tests.tgz" -C "$work/t" .
(cd "$out" && apt-get download libvulkan1 libglvnd0 libegl1 libgl1 libglx0 libgles2 libopengl0)
cp tools/gpu_check/check.sh "$out/"
du -sh "$out"
