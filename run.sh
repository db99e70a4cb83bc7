#!/usr/bin/env bash
# The main job: builds everything, then opens the viewer when a display is available, else renders the default
# Cornell box headless to cornell.png and cornell.pfm in the current directory. Extra arguments go to
# `pathtracer render` (e.g. ./run.sh --spp 256).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
"$here/tools/bootstrap.sh"
exe="$here/build/app/pathtracer"
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ] && "$exe" --help 2>/dev/null | grep -q '^ *view'; then
  exec "$exe" view "$@"
fi
[ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ] || echo "No display found: rendering headless." >&2
exec "$exe" render --scene cornell --png cornell.png --pfm cornell.pfm "$@"
