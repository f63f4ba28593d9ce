#!/usr/bin/env bash
# The ISO 9283 pose test on the IPA UR10's real data (tests/realdata/ipa_iso9283.py says what and checks).
# Usage: ipa_iso9283.sh BUILD_DIR
exec bash "$(dirname "$0")/run_python.sh" "$1" ipa_iso9283.py
