# Starting and stopping a robocal-server for scripts: a free port (the server picks it: --port 0), a temporary
# database, and the server stopped when the script exits. Source it, then: start_server BUILD_DIR [server flags].
# Sets ROBOCAL_URL and SERVER_PID; SERVER_TMP holds the database and the server's log.

# shellcheck source=listening_line.sh
source "$(dirname "${BASH_SOURCE[0]}")/listening_line.sh"

start_server() {
  local build_dir=$1
  shift
  SERVER_TMP=$(mktemp -d)
  mkfifo "$SERVER_TMP/server.out"
  "$build_dir/server/robocal-server" --port 0 --db "$SERVER_TMP/robocal.db" --log-level warn "$@" \
    >"$SERVER_TMP/server.out" 2>"$SERVER_TMP/server.log" &
  SERVER_PID=$!
  trap stop_server EXIT
  ROBOCAL_URL=$(read_listening_line "$SERVER_TMP/server.out")
  if [ -z "$ROBOCAL_URL" ]; then
    echo "robocal-server did not start:" >&2
    cat "$SERVER_TMP/server.log" >&2
    return 1
  fi
}

stop_server() {
  if [ -n "${SERVER_PID:-}" ]; then
    kill -TERM "$SERVER_PID" 2>/dev/null || true
    wait "$SERVER_PID" 2>/dev/null || true
    SERVER_PID=
  fi
  [ -n "${SERVER_TMP:-}" ] && rm -rf "$SERVER_TMP"
  SERVER_TMP=
}
