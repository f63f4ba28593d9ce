#!/usr/bin/env bash
# make demo: a robocal-server on a free port with a temporary database, the mock tracker calibrating a
# simulated grinder5 (10 planned pose configurations) through it, the paper's accuracy table, server stopped.
# Usage: tests/curl/demo.sh [BUILD_DIR] [extra robocal-mock-tracker options]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build_dir=${1:-build}
shift || true
source "$here/server.sh"
start_server "$build_dir"
echo "robocal-server running at $ROBOCAL_URL (temporary database)"
"$build_dir/client/robocal-mock-tracker" --server "$ROBOCAL_URL" --robot grinder5 --count 10 --type pose "$@"
