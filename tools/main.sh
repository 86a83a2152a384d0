#!/usr/bin/env bash
# The main job: install what is missing, build, run the map-based EV on NEDC, print the
# summary and write outputs and plots to out/ev_nedc/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/tools/setup.sh"
cd "$here"
exec ./build/ehpt run ev_nedc --out out/ev_nedc --plot "$@"
