#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) with clang-14, AddressSanitizer and UndefinedBehaviorSanitizer into
# build-asan/ (the sanitizer build of test.sh, which shares the instrumented library with them), and runs each
# for SECONDS (default 30). The working corpus stays in build-asan/fuzz-corpus/ between runs (seeded from
# scenes/ and tests/fuzz/seeds/); a crash, sanitizer report, leak, timeout or out-of-memory input is saved under
# build-asan/fuzz-findings/ and makes the script exit 1. See docs/reliability.md.
#   tools/fuzz.sh [SECONDS] [TARGET...]      e.g. tools/fuzz.sh 1800 fuzz_scene
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
shift || true
targets=("$@")
((${#targets[@]})) || targets=(fuzz_scene fuzz_images fuzz_geometry_files fuzz_film_state fuzz_gltf fuzz_texture)

tools/install_packages.sh clang-14 libclang-rt-14-dev

build=build-asan
cmake -S . -B "$build" -DPT_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 >/dev/null
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}"

status=0
for t in "${targets[@]}"; do
  corpus="$build/fuzz-corpus/$t"
  findings="$build/fuzz-findings/$t"
  mkdir -p "$corpus" "$findings"
  case "$t" in
    fuzz_scene)  seeds=(scenes); extra=(-dict=tests/fuzz/scene.dict -max_len=16384) ;;
    fuzz_images) seeds=(tests/fuzz/seeds/images); extra=(-max_len=4096) ;;
    fuzz_geometry_files) seeds=(tests/fuzz/seeds/geometry); extra=(-max_len=4096) ;;
    fuzz_film_state) seeds=(tests/fuzz/seeds/states); extra=(-max_len=4096) ;;
    fuzz_gltf) seeds=(tests/fuzz/seeds/gltf); extra=(-max_len=8192) ;;
    fuzz_texture) seeds=(tests/fuzz/seeds/textures); extra=(-max_len=4096) ;;
    *) echo "unknown fuzz target $t" >&2; exit 2 ;;
  esac
  echo "== $t: ${seconds} s =="
  # -timeout: one input taking longer than 10 s is a hang; -rss_limit_mb: memory beyond 2.5 GiB is a finding.
  if ! "$build/tests/fuzz/$t" "$corpus" "${seeds[@]}" "${extra[@]}" -max_total_time="$seconds" \
       -timeout=10 -rss_limit_mb=2560 -print_final_stats=1 -artifact_prefix="$findings/" 2>"$build/$t.log"; then
    status=1
    echo "$t: FINDING ($build/$t.log, $findings/):" >&2
    grep -E 'ERROR|SUMMARY|fuzz_(scene|images|geometry_files|film_state|gltf|texture):|Test unit written' "$build/$t.log" | head -20 >&2
  fi
  grep -E '^stat::(number_of_executed_units|peak_rss_mb)|cov: ' "$build/$t.log" | tail -3
done
exit $status
