#!/usr/bin/env bash
# Parallel efficiency of `render --mpi` on this machine (docs/scale-out.md): a SECONDS-long render of SCENE with
# 1 process × 1 thread, then with N ranks × 1 thread, alternately RUNS times; prints samples/s and the efficiency
# per added rank (N-rank samples/s over N × 1-process samples/s) of each run. A benchmark: it prints, never fails
# on a figure.
#   tools/mpi_efficiency.sh [N=2] [SECONDS=30] [RUNS=2] [SCENE=cornell]
set -euo pipefail
cd "$(dirname "$0")/.."
ranks=${1:-2} seconds=${2:-30} runs=${3:-2} scene=${4:-cornell}
exe=build/app/pathtracer
root=(); [[ $(id -u) == 0 ]] && root=(--allow-run-as-root)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
rate() { grep -o '[0-9.]* Msamples/s' "$1" | cut -d' ' -f1; }
for ((i = 1; i <= runs; ++i)); do
  "$exe" render --scene "$scene" --time "$seconds" --seed 1 --threads 1 -q --pfm "$out/one.pfm" > "$out/one.txt"
  mpirun "${root[@]}" --oversubscribe -np "$ranks" "$exe" render --mpi --scene "$scene" --time "$seconds" --seed 1 \
    --threads 1 -q --pfm "$out/many.pfm" > "$out/many.txt"
  one=$(rate "$out/one.txt") many=$(rate "$out/many.txt")
  echo "run $i: 1 x 1 thread $one Msamples/s, $ranks ranks x 1 thread $many Msamples/s, efficiency per rank" \
       "$(awk -v a="$one" -v b="$many" -v n="$ranks" 'BEGIN { printf "%.0f %%", 100 * b / (n * a) }')"
  grep '^mpi:' "$out/many.txt" || true
done
