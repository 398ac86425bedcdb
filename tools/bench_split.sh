#!/usr/bin/env bash
# Splitting one render: the same total passes rendered by one device, by two
# PoCL devices in one process, and by 1 and 2 MPI ranks, on this machine.
# Prints the median of RUNS runs of each configuration (rounds interleave the
# configurations): the whole command's wall clock, the renderer's own
# "passes in X s", the CPU time (user + system) of every process of the
# command, and the speed-up in wall clock over one device; checks that every
# configuration wrote the same image, bit for bit. Needs bash, awk, PoCL and
# (for the MPI rows) Open MPI's mpirun.
#
#   tools/bench_split.sh                      # Fig. 3 (a) settings, 8 passes
#   PASSES=4 tools/bench_split.sh -D streams=10000 -D associated=100   # Fig. 3 (b)
#
# Environment: BUILD (build), SCENE (scenes/cornell_fog.xml), PASSES (8),
# RUNS (3), OUT (a scratch directory), MPI (1; 0 leaves out the MPI rows).
# Arguments: more `spm render` options; without any, Fig. 3 (a)'s
# `-D streams=1000 -D associated=10`.
# Configurations:
#   1 device                 PoCL's default: one CPU device, a thread per core
#   2 devices                POCL_DEVICES="pthread pthread" --device all: two
#                            CPU devices; PoCL's pthread devices share one
#                            pool of worker threads (a thread per core), so
#                            the cores are not oversubscribed
#   mpirun -np 1             one rank
#   mpirun -np 2, unbound    each rank's device may use every core, as one
#                            process's does
#   mpirun -np 2, bound      Open MPI's default binding: a core per rank
# Other work on the machine skews the comparison (more threads get more of a
# loaded machine): check `uptime` first.
set -euo pipefail
cd "$(dirname "$0")/.."

BUILD=${BUILD:-build}
SCENE=${SCENE:-scenes/cornell_fog.xml}
PASSES=${PASSES:-8}
RUNS=${RUNS:-3}
MPI=${MPI:-1}
OUT=${OUT:-$(mktemp -d)}
SPM="$BUILD/spm"
[ -x "$SPM" ] || { echo "bench_split: $SPM not built" >&2; exit 2; }
if [ $# -eq 0 ]; then set -- -D streams=1000 -D associated=10; fi
mkdir -p "$OUT"

names=("1 device" "2 devices")
if [ "$MPI" = 1 ]; then
  command -v mpirun >/dev/null || { echo "bench_split: mpirun not found (openmpi-bin); MPI=0 leaves out the MPI rows" >&2; exit 2; }
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  names+=("mpirun -np 1" "mpirun -np 2, unbound" "mpirun -np 2, bound")
fi

# run_config I OUT.exr ARGS...: configuration I's command.
run_config() {
  local i=$1 out=$2
  shift 2
  local render=("$SPM" render "$SCENE" -o "$out" --passes "$PASSES" "$@")
  case $i in
    0) "${render[@]}" ;;
    1) POCL_DEVICES="pthread pthread" "${render[@]}" --device all ;;
    2) mpirun -np 1 --bind-to none "${render[@]}" ;;
    3) mpirun -np 2 --bind-to none "${render[@]}" ;;
    4) mpirun -np 2 "${render[@]}" ;;
  esac
}

median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

echo "bench_split: $SCENE, $PASSES passes, $* ; $RUNS runs each after a warm-up; $(nproc) cores; load: $(cut -d' ' -f1-3 /proc/loadavg)"
# Warm-up: PoCL's kernel cache, the page cache.
"$SPM" render "$SCENE" -o "$OUT/warm.exr" --passes 1 "$@" 2>/dev/null

# Rounds interleave the configurations, so that a change in the machine's
# load between rounds reaches every configuration alike.
# bash's `time` gives the wall clock and the CPU time of every process the
# command started (mpirun's ranks included).
declare -A wall cpu inner
TIMEFORMAT='%R %U %S'
for run in $(seq "$RUNS"); do
  for i in "${!names[@]}"; do
    times=$( { time run_config "$i" "$OUT/c$i.exr" "$@" 2>"$OUT/c$i.log"; } 2>&1 )
    read -r real user sys <<<"$times"
    wall[$i]+="$real "
    cpu[$i]+="$(awk -v a="$user" -v b="$sys" 'BEGIN { print a + b }') "
    inner[$i]+="$(sed -n 's/.*passes in \([0-9.]*\) s.*/\1/p' "$OUT/c$i.log") "
    if [ "$i" -gt 0 ] && ! cmp -s "$OUT/c0.exr" "$OUT/c$i.exr"; then
      echo "bench_split: ${names[$i]} wrote another image than one device" >&2
      exit 1
    fi
  done
done

printf '%-28s %8s %10s %8s %9s   %s\n' configuration "wall s" "passes s" "CPU s" speedup "(wall s of each run)"
base=""
for i in "${!names[@]}"; do
  # shellcheck disable=SC2086
  w=$(printf '%s\n' ${wall[$i]} | median)
  # shellcheck disable=SC2086
  p=$(printf '%s\n' ${inner[$i]} | median)
  # shellcheck disable=SC2086
  c=$(printf '%s\n' ${cpu[$i]} | median)
  [ -n "$base" ] || base=$w
  printf '%-28s %8.2f %10.2f %8.2f %8.2fx   (%s)\n' "${names[$i]}" "$w" "$p" "$c" \
    "$(awk -v a="$base" -v b="$w" 'BEGIN { print a / b }')" "$(printf '%.2f ' ${wall[$i]} | sed 's/ $//')"
done
echo "bench_split: every configuration wrote the same image; load after: $(cut -d' ' -f1-3 /proc/loadavg)"
