#!/usr/bin/env bash
# make demo: a robocal-server on a free port with a temporary database, the mock tracker calibrating simulated
# grinder5 cells through it in the paper's setting (10 planned pose configurations, 10 shots per pose, 36
# validation poses) in the realistic cell (the preset cell, the tracker's datasheet uncertainty, 0.03 mm robot
# repeatability, 2 % outliers), planned against random configurations over 5 cells, the paper's tables, server
# stopped.
# Usage: tests/curl/demo.sh [BUILD_DIR] [robocal-mock-tracker options, replacing --compare random --trials 5
#        --realistic]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build_dir=${1:-build}
shift || true
# One comparison of one planned and one random set is mostly noise; five cells pooled say more.
[ $# -eq 0 ] && set -- --compare random --trials 5 --realistic
source "$here/server.sh"
start_server "$build_dir"
echo "robocal-server running at $ROBOCAL_URL (temporary database)"
"$build_dir/client/robocal-mock-tracker" --server "$ROBOCAL_URL" --robot grinder5 --count 10 --type pose \
  --shots 10 --validation 36 "$@"
