#!/usr/bin/env bash
# Drift checks on the IPA UR10's real data (tests/realdata/ipa_drift.py says what and checks).
# Usage: ipa_drift.sh BUILD_DIR
exec bash "$(dirname "$0")/run_python.sh" "$1" ipa_drift.py
