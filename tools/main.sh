#!/usr/bin/env bash
# The main job: install what is missing, build, run the paper's PSecu2 (power-split hybrid
# with MBecu2) on NEDC, print the summary and write outputs and plots to out/psecu2_nedc/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/tools/setup.sh"
cd "$here"
exec ./build/ehpt run psecu2_nedc --out out/psecu2_nedc --plot "$@"
