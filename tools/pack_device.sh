#!/bin/bash
# Packs a self-contained spm for a machine without a package registry, such
# as a lent GPU machine (issue 14, item 6): build/spm, every shared library
# it links except glibc's own (the target must have glibc >= this machine's),
# the scenes, the committed references and tools/device_run.sh.
#
#   tools/pack_device.sh [BUILD_DIR] [OUT.tar.gz]     (default: build, build/spm-device.tar.gz)
#
# On the target: tar xzf spm-device.tar.gz && spm-device/device_run.sh OUT_DIR
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
out=${2:-$build/spm-device.tar.gz}
[ -x "$build/spm" ] || { echo "pack_device.sh: no $build/spm (build first: bash tools/setup.sh)" >&2; exit 2; }
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
pack=$stage/spm-device
mkdir -p "$pack/bin" "$pack/lib" "$pack/reference"
cp "$build/spm" "$pack/bin/"
# The loader resolves these from LD_LIBRARY_PATH (device_run.sh sets it);
# glibc's libraries stay the target's, which must match its ld.so.
ldd "$build/spm" | awk '/=> \// {print $3}' | while read -r lib; do
  case $(basename "$lib") in
    libc.so.* | libm.so.* | libdl.so.* | libpthread.so.* | librt.so.* | ld-linux*) ;;
    *) cp -L "$lib" "$pack/lib/" ;;
  esac
done
cp -r "$root/scenes" "$pack/"
cp "$root"/tests/data/reference/*.exr "$root"/tests/data/reference/*.json "$pack/reference/"
cp "$root/tools/device_run.sh" "$pack/"
git -C "$root" rev-parse HEAD > "$pack/COMMIT" 2>/dev/null || echo unknown > "$pack/COMMIT"
tar -C "$stage" -czf "$out" spm-device
echo "pack_device.sh: wrote $out ($(du -h "$out" | cut -f1))"
