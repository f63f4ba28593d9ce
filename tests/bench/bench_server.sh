# Sourced by the benchmark scripts of this folder: starts and stops a robocal-server on a free port with a
# database in $work (which the caller creates and removes). After bench_start_server, $server_pid and $url are
# set; bench_stop_server is safe to call more than once (e.g. from an EXIT trap).
#
#   bench_start_server NAME SERVER_BINARY [server options...]   (NAME prefixes the error messages)

server_pid=
url=

bench_start_server() {
  local name=$1 binary=$2
  shift 2
  # Port 0: the server picks a free port and names it on its first line.
  "$binary" --port 0 --db "$work/robocal.db" --log-level warn "$@" >"$work/stdout" 2>"$work/stderr" &
  server_pid=$!
  for _ in $(seq 100); do
    grep -q 'listening on' "$work/stdout" 2>/dev/null && break
    sleep 0.1
  done
  url=$(sed -n 's/.*listening on \(http[^ ]*\).*/\1/p' "$work/stdout")
  [ -n "$url" ] || { echo "$name: the server did not start" >&2; cat "$work/stderr" >&2; exit 1; }
}

bench_stop_server() {
  if [ -n "$server_pid" ]; then kill -TERM "$server_pid" 2>/dev/null || true; wait "$server_pid" 2>/dev/null || true; fi
  server_pid=
}
