#!/usr/bin/env bash
# Plans from a cell's own poses on the IPA UR10's real data (tests/realdata/ipa_planning.py says what and checks).
# Usage: ipa_planning.sh BUILD_DIR
exec bash "$(dirname "$0")/run_python.sh" "$1" ipa_planning.py
