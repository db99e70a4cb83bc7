#!/usr/bin/env bash
# Installs the Debian packages the project needs (only the missing ones) and builds it incrementally into
# build/ (Release). Used by run.sh and test.sh; safe to run again at any time.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config          # toolchain
  libglm-dev nlohmann-json3-dev libstb-dev  # maths, scene files, PNG
  rapidjson-dev                             # the fast scene-file reader
  libcli11-dev doctest-dev                  # command line, tests
  libglfw3-dev libgl-dev libimgui-dev       # viewer window, GL, UI
  libosmesa6-dev xvfb xauth libgl1-mesa-dri # headless GL tests, window tests without a display (xvfb-run needs xauth)
  xdotool x11-apps                          # window tests: unmap/map the viewer's window, capture the screen (xwd)
  gnuplot-nox                               # the convergence plots of `pathtracer bench`
  libopenexr-dev                            # HDR environment maps, multi-layer film output (.exr)
  openexr                                   # exrheader: the tests check the layers other tools will see
  libtinyobjloader-dev                      # OBJ meshes
  libtinygltf-dev                           # glTF 2.0 scenes
  assimp-testmodels                         # tests: the glTF 2.0 corpus (well-formed and broken files)
  libopenmpi-dev openmpi-bin                # render --mpi (scale-out over ranks and machines)
)

tools/install_packages.sh "${PACKAGES[@]}"

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
