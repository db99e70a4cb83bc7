#!/usr/bin/env bash
# Builds everything and runs the whole test suite (doctest cases through ctest, both cores).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
"$here/tools/bootstrap.sh"
cd "$here/build"
ctest -j"$(nproc)" --output-on-failure --timeout 600
