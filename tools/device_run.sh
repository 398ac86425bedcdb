#!/bin/bash
# Runs on a device machine from the unpacked tools/pack_device.sh folder, in
# one short command: registers NVIDIA's OpenCL driver when the machine has
# one (libnvidia-opencl.so.1 in the driver's folder, an ICD file pointing at
# it, OCL_ICD_VENDORS pointing at that), then writes to OUT_DIR:
#   devices.txt                spm devices
#   bench.txt, bench.json      spm bench --quick on spm's default device: the
#                              first GPU, else the first CPU
#   cornell_fog_timed.*        a timed render of scenes/cornell_fog.xml at the
#                              reference's 64x64, and its relMSE (spm compare)
#   log.txt                    what ran, and how long
#
#   spm-device/device_run.sh OUT_DIR [SECONDS]    (SECONDS: the timed render's budget, default 10)
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: device_run.sh OUT_DIR [SECONDS]}
budget=${2:-10}
mkdir -p "$out"
log=$out/log.txt
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
spm=$here/bin/spm
step() {  # step NAME COMMAND...: runs it, its output to OUT_DIR/NAME, its status and time to the log
  local name=$1 start=$SECONDS
  shift
  "$@" > "$out/$name" 2>&1
  local rc=$?
  echo "$name: exit $rc in $((SECONDS - start)) s: $*" >> "$log"
  return $rc
}

echo "commit $(cat "$here/COMMIT"), $(date -u)" > "$log"
driver=""
for dir in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib /usr/local/nvidia/lib64 /usr/local/nvidia/lib \
  /usr/lib/nvidia /usr/local/cuda/lib64 /opt/nvidia/lib64; do
  if [ -e "$dir/libnvidia-opencl.so.1" ]; then driver=$dir/libnvidia-opencl.so.1; break; fi
done
if [ -z "$driver" ] && command -v ldconfig > /dev/null; then
  driver=$(ldconfig -p 2>/dev/null | awk '/libnvidia-opencl.so.1/ {print $NF; exit}')
fi
if [ -n "$driver" ]; then
  mkdir -p "$out/icd"
  echo "$driver" > "$out/icd/nvidia.icd"
  export OCL_ICD_VENDORS=$out/icd
  echo "NVIDIA OpenCL driver: $driver" >> "$log"
else
  echo "no libnvidia-opencl.so.1 found: the system's OpenCL vendors as they are" >> "$log"
fi
command -v nvidia-smi > /dev/null && step nvidia-smi.txt nvidia-smi

step devices.txt "$spm" devices || { echo "device_run.sh: spm devices failed, see $out/devices.txt" >&2; exit 1; }
step bench.txt "$spm" bench --quick --repeat 3 --scenes "$here/scenes" --json "$out/bench.json"
step cornell_fog_timed.txt "$spm" render "$here/scenes/cornell_fog.xml" -D res=64 --time "$budget" \
  -o "$out/cornell_fog_timed.exr" --profile-json "$out/cornell_fog_timed.json"
[ -f "$out/cornell_fog_timed.exr" ] &&
  step cornell_fog_timed_compare.txt "$spm" compare "$out/cornell_fog_timed.exr" "$here/reference/cornell_fog.exr"
echo "device_run.sh: results in $out"
cat "$log"
