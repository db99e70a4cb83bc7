#!/usr/bin/env bash
# Renders every built-in scene and the bunny mesh scene at 96x96, 8 spp, seed 1 into OUT/NAME.pfm with the given
# pathtracer binary: run it with the binaries before and after a change that must not alter images (moving code,
# renaming), then `cmp` the two folders (or pass --compare DIR_A DIR_B). Issue 38's proof of "behaviour unchanged".
# Usage: tools/identical_images.sh PATHTRACER OUT
#        tools/identical_images.sh --compare DIR_A DIR_B
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
if [ "${1:-}" = "--compare" ]; then
  status=0
  for a in "$2"/*.pfm; do
    b="$3/$(basename "$a")"
    if cmp -s "$a" "$b"; then echo "identical: $(basename "$a")"; else echo "DIFFERENT: $(basename "$a")"; status=1; fi
  done
  exit $status
fi
bin="$1"
out="$2"
mkdir -p "$out"
for scene in cornell cornell-spheres shadertoy materials sky "$here/scenes/cornell-bunny.json"; do
  name="$(basename "$scene" .json)"
  "$bin" render --scene "$scene" --width 96 --height 96 --spp 8 --seed 1 --threads 2 --pfm "$out/$name.pfm" \
    --png "$out/$name.png" > /dev/null
done
echo "wrote $(ls "$out"/*.pfm | wc -l) PFMs to $out"
