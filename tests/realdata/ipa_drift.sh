#!/usr/bin/env bash
# Drift checks on the IPA UR10's real data (tests/realdata/ipa_drift.py says what and checks).
# Usage: ipa_drift.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../curl/server.sh
source "$here/../curl/server.sh"
start_server "$build"
trap stop_server EXIT
python3 "$here/ipa_drift.py" "$ROBOCAL_URL" "$here/../data"
