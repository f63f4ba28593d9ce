# Starting and stopping a robocal-server for scripts: a free port (the server picks it: --port 0), a temporary
# database, and the server stopped when the script exits. Source it, then: start_server BUILD_DIR [server flags].
# Sets ROBOCAL_URL and SERVER_PID; SERVER_TMP holds the database and the server's log.

start_server() {
  local build_dir=$1
  shift
  SERVER_TMP=$(mktemp -d)
  "$build_dir/server/robocal-server" --port 0 --db "$SERVER_TMP/robocal.db" --log-level warn "$@" \
    >"$SERVER_TMP/server.out" 2>"$SERVER_TMP/server.log" &
  SERVER_PID=$!
  trap stop_server EXIT
  ROBOCAL_URL=
  # The server prints its URL once it is bound; wait for that line (up to 10 s).
  for _ in $(seq 1 100); do
    ROBOCAL_URL=$(sed -n 's/^robocal-server listening on \([^ ]*\).*/\1/p' "$SERVER_TMP/server.out")
    [ -n "$ROBOCAL_URL" ] && break
    kill -0 "$SERVER_PID" 2>/dev/null || break
    sleep 0.1
  done
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
