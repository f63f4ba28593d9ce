#!/usr/bin/env bash
# Runs one of the real-data scripts against a robocal-server of its own, started from BUILD_DIR and stopped after.
# Usage: run_python.sh BUILD_DIR SCRIPT.py (a script of this folder, given the server's URL and tests/data)
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../curl/server.sh
source "$here/../curl/server.sh"
start_server "$build"
trap stop_server EXIT
python3 "$here/$2" "$ROBOCAL_URL" "$here/../data"
