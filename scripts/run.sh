#!/usr/bin/env bash
# The run command (README): installs what is missing, builds lipmap into build/ (Release, ccache) and
# runs its main job. For now that is classifying a boundary polygon (default: the bundled example, a
# strip wound 1.25 turns along a spiral, which is self-overlapping) and printing the answer; once the
# HTTP service lands, this starts it.
#
#   bash scripts/run.sh [POLYGON.json]
#
# Environment: LIPMAP_BUILD_DIR (default build), LIPMAP_JOBS (default 2).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build_dir="${LIPMAP_BUILD_DIR:-build}"
jobs="${LIPMAP_JOBS:-2}"
polygon="${1:-tests/data/polygons/spiral_overlapping.json}"

bash scripts/setup.sh
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >&2
cmake --build "$build_dir" -j "$jobs" --target lipmap >&2
echo "lipmap classify --pretty $polygon" >&2
exec "$build_dir/server/lipmap" classify --pretty "$polygon"
