#!/usr/bin/env bash
# The campaign report in a real browser: a robocal-server with a temporary database, a campaign planned in the
# grinder5's preset cell and calibrated by the mock tracker (plan, calibration with outliers, validation), its
# report rendered by headless Chromium to a PNG and to the DOM Chromium built; check_report_page.py then checks
# that the PNG is not blank and that the DOM's tables hold the numbers of GET .../calibration and :evaluate.
# Usage: tests/curl/report_browser_test.sh BUILD_DIR [SCREENSHOT.png]   (the screenshot of docs/report.md)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build_dir=$(cd "${1:?usage: report_browser_test.sh BUILD_DIR [SCREENSHOT.png]}" && pwd)
screenshot_out=${2:-}
source "$here/server.sh"

chromium_bin=${ROBOCAL_CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}
if [ -z "$chromium_bin" ]; then
  echo "FAIL: chromium not found (deploy/install-deps.sh installs the Debian package chromium)" >&2
  exit 1
fi

work=$(mktemp -d)
browser_pgid=
cleanup() {
  # Chromium starts helpers (zygote, GPU, renderers) in its own process group: end the whole group.
  if [ -n "$browser_pgid" ]; then kill -KILL -- "-$browser_pgid" 2>/dev/null || true; fi
  stop_server
  rm -rf "$work"
}
trap cleanup EXIT
start_server "$build_dir"
trap cleanup EXIT

# A calibrated campaign: planned in the preset cell, 3 shots per pose with 3 % outliers, 24 validation poses.
timeout 240 "$build_dir/client/robocal-mock-tracker" --server "$ROBOCAL_URL" --robot grinder5 --cell preset \
  --count 12 --shots 3 --validation 24 --outliers 0.03 --seed 4 --json >"$work/mock.json"
campaign=$(jq -r '.trials[0].planned.campaign' "$work/mock.json")
echo "campaign $campaign"

curl -sS -f -o "$work/calibration.json" "$ROBOCAL_URL/v1/campaigns/$campaign/calibration"
curl -sS -f -o "$work/evaluation.json" -H 'Content-Type: application/json' --data-binary '{"h_mm": 30}' \
  "$ROBOCAL_URL/v1/campaigns/$campaign:evaluate"
plan=$(jq -r '.trials[0].planned.plan' "$work/mock.json")
curl -sS -f -o "$work/plan.json" "$ROBOCAL_URL/v1/plans/$plan"
curl -sS -f -D "$work/headers" -o "$work/report.html" "$ROBOCAL_URL/v1/campaigns/$campaign/report"
grep -qi '^content-type: text/html; charset=utf-8' "$work/headers" || {
  echo "FAIL: the report's Content-Type is not text/html; charset=utf-8" >&2
  cat "$work/headers" >&2
  exit 1
}

# Headless Chromium on the page as the server serves it (its headers, its CSP), with a profile and HOME of its
# own; in a new session, so that every helper it starts can be ended with it. As root it needs --no-sandbox.
run_chromium() {
  local out=$1
  shift
  mkdir -p "$work/home"
  HOME="$work/home" setsid "$chromium_bin" --headless --no-sandbox --disable-gpu --disable-dev-shm-usage \
    --no-first-run --no-default-browser-check --disable-extensions --disable-background-networking \
    --hide-scrollbars --user-data-dir="$work/profile" --virtual-time-budget=5000 "$@" \
    "$ROBOCAL_URL/v1/campaigns/$campaign/report" >"$out" 2>"$work/chromium.log" &
  browser_pgid=$!
  # Until it exits (no time limit: a busy machine is slower; a hang is the test runner's timeout's).
  wait "$browser_pgid" || {
    echo "FAIL: chromium exited with an error" >&2
    tail -20 "$work/chromium.log" >&2
    return 1
  }
  kill -KILL -- "-$browser_pgid" 2>/dev/null || true
  browser_pgid=
}
run_chromium "$work/shot.log" --screenshot="$work/report.png" --window-size=1100,2400
run_chromium "$work/dom.html" --dump-dom

python3 "$here/check_report_page.py" "$work/report.png" "$work/dom.html" "$work/calibration.json" \
  "$work/evaluation.json" "$work/plan.json"
if [ -n "$screenshot_out" ]; then
  cp "$work/report.png" "$screenshot_out"
  echo "screenshot: $screenshot_out"
fi
