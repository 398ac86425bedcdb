#!/usr/bin/env bash
# MPI benchmark: the same total passes rendered by one process and by 2 MPI
# ranks on this machine. Prints the median of RUNS runs of each configuration
# (rounds interleave the configurations): the whole command's wall clock, the
# renderer's own "passes in X s", the CPU time (user + system) of every
# process of the command, and the speed-up in wall clock over one process;
# checks that every configuration wrote the same image, bit for bit. Needs
# bash, awk and Open MPI's mpirun only.
#
#   tools/bench_mpi.sh                        # Fig. 3 (a) settings, 8 passes
#   PASSES=4 tools/bench_mpi.sh -D streams=10000 -D associated=100   # Fig. 3 (b)
#
# Environment: BUILD (build), SCENE (scenes/cornell_fog.xml), PASSES (8),
# RUNS (3), OUT (a scratch directory). Arguments: more `spm render` options;
# without any, Fig. 3 (a)'s `-D streams=1000 -D associated=10`.
# Configurations: one process without mpirun; mpirun -np 1; mpirun -np 2
# without binding (each rank's PoCL device may use every core, as one
# process's does); mpirun -np 2 with Open MPI's default binding on 2 ranks
# (one core per rank). Other work on the machine skews the comparison (more
# processes get more of a loaded machine): check `uptime` first.
set -euo pipefail
cd "$(dirname "$0")/.."

BUILD=${BUILD:-build}
SCENE=${SCENE:-scenes/cornell_fog.xml}
PASSES=${PASSES:-8}
RUNS=${RUNS:-3}
OUT=${OUT:-$(mktemp -d)}
SPM="$BUILD/spm"
[ -x "$SPM" ] || { echo "bench_mpi: $SPM not built" >&2; exit 2; }
command -v mpirun >/dev/null || { echo "bench_mpi: mpirun not found (openmpi-bin)" >&2; exit 2; }
if [ $# -eq 0 ]; then set -- -D streams=1000 -D associated=10; fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mkdir -p "$OUT"

names=("1 process" "mpirun -np 1" "mpirun -np 2, --bind-to none" "mpirun -np 2, bound to cores")
launchers=("" "mpirun -np 1 --bind-to none" "mpirun -np 2 --bind-to none" "mpirun -np 2")

median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

echo "bench_mpi: $SCENE, $PASSES passes, $* ; $RUNS runs each after a warm-up; $(nproc) cores; load: $(cut -d' ' -f1-3 /proc/loadavg)"
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
    # shellcheck disable=SC2086
    times=$( { time ${launchers[$i]} "$SPM" render "$SCENE" -o "$OUT/c$i.exr" --passes "$PASSES" "$@" \
                 2>"$OUT/c$i.log"; } 2>&1 )
    read -r real user sys <<<"$times"
    wall[$i]+="$real "
    cpu[$i]+="$(awk -v a="$user" -v b="$sys" 'BEGIN { print a + b }') "
    inner[$i]+="$(sed -n 's/.*passes in \([0-9.]*\) s.*/\1/p' "$OUT/c$i.log") "
    if [ "$i" -gt 0 ] && ! cmp -s "$OUT/c0.exr" "$OUT/c$i.exr"; then
      echo "bench_mpi: ${names[$i]} wrote another image than one process" >&2
      exit 1
    fi
  done
done

printf '%-32s %8s %10s %8s %9s   %s\n' configuration "wall s" "passes s" "CPU s" speedup "(wall s of each run)"
base=""
for i in "${!names[@]}"; do
  # shellcheck disable=SC2086
  w=$(printf '%s\n' ${wall[$i]} | median)
  # shellcheck disable=SC2086
  p=$(printf '%s\n' ${inner[$i]} | median)
  # shellcheck disable=SC2086
  c=$(printf '%s\n' ${cpu[$i]} | median)
  [ -n "$base" ] || base=$w
  printf '%-32s %8.2f %10.2f %8.2f %8.2fx   (%s)\n' "${names[$i]}" "$w" "$p" "$c" \
    "$(awk -v a="$base" -v b="$w" 'BEGIN { print a / b }')" "$(printf '%.2f ' ${wall[$i]} | sed 's/ $//')"
done
echo "bench_mpi: every configuration wrote the same image; load after: $(cut -d' ' -f1-3 /proc/loadavg)"
