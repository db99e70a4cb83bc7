#!/usr/bin/env bash
# Builds everything and runs the whole test suite (doctest cases through ctest, all cores).
# With CI=true (as in CI) or with --sanitize, then also builds the tracer and its tests with clang 14,
# AddressSanitizer and UndefinedBehaviorSanitizer (build-asan/, beside the libFuzzer targets) and runs the fast
# suites under them: scene files, intersection, sampling, film, materials, furnace, determinism, CLI error paths,
# film states and merges; and runs each libFuzzer target (scene loader, image readers, geometry files, film
# states, glTF, textures) for 30 s under ASan/UBSan (tools/fuzz.sh; a finding fails the run).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
"$here/tools/bootstrap.sh"
cd "$here/build"
ctest -j"$(nproc)" --output-on-failure --timeout 600

if [ "${CI:-}" = "true" ] || [ "${1:-}" = "--sanitize" ]; then
  echo "== sanitizer build (clang, ASan + UBSan) =="
  "$here/tools/install_packages.sh" clang-14 libclang-rt-14-dev
  cmake -S "$here" -B "$here/build-asan" -DPT_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_COMPILER=clang++-14 >/dev/null
  cmake --build "$here/build-asan" -j"$(nproc)" --target tracer_tests pathtracer
  cd "$here/build-asan"
  ctest -j"$(nproc)" --output-on-failure --timeout 900 \
    -R 'scene_json|intersection|watertight|sphere|film:|fresnel|energy|refraction|sampling|rng|cli: errors|PFM round|metrics|furnace|determinism|bsdf|environment|spherical rectangle|analytic irradiance|safe writes|safe reads|cli: bad option|cli: outputs|cli: a write|typed edits|hostile scene input|features:|film halves|exr:|denoiser: both filters keep a constant|denoiser: the regression reproduces|denoiser: both filters take|denoiser: the regression stops|denoiser: the regression spreads|fireflies:|wavefront: the shading lanes|scale-out: |render region|gltf:|thin lens|smooth shading:|obj materials:|textures:|punctual lights:|normal maps:|cut-outs:|emission textures:|instances:' \
    -E 'default scene|just below 1|albedo-1 closed room|cornell, 1 bounce|agreement:|constant map renders'
  echo "== fuzzing (libFuzzer, ASan + UBSan), 30 s per target =="
  "$here/tools/fuzz.sh" 30
fi
