# Sourced by the benchmark scripts of this folder: starts and stops a robocal-server on a free port with a
# database in $work (which the caller creates and removes). After bench_start_server, $server_pid and $url are
# set; bench_stop_server is safe to call more than once (e.g. from an EXIT trap).
#
#   bench_start_server NAME SERVER_BINARY [server options...]   (NAME prefixes the error messages)

server_pid=
url=

# shellcheck source=../curl/listening_line.sh
source "$(dirname "${BASH_SOURCE[0]}")/../curl/listening_line.sh"

bench_start_server() {
  local name=$1 binary=$2
  shift 2
  # Port 0: the server picks a free port and names it on its first line, once bound (read_listening_line).
  rm -f "$work/stdout"
  mkfifo "$work/stdout"
  "$binary" --port 0 --db "$work/robocal.db" --log-level warn "$@" >"$work/stdout" 2>"$work/stderr" &
  server_pid=$!
  url=$(read_listening_line "$work/stdout")
  [ -n "$url" ] || { echo "$name: the server did not start" >&2; cat "$work/stderr" >&2; exit 1; }
}

bench_stop_server() {
  if [ -n "$server_pid" ]; then kill -TERM "$server_pid" 2>/dev/null || true; wait "$server_pid" 2>/dev/null || true; fi
  server_pid=
}

# write_batch_lua FILE: a wrk script that POSTs batches of 50 measurements, each with a request_id of its own
# (so that every request is stored, none replayed), to campaign args[1] (default "load"); args[2] (default "t")
# prefixes the request ids, so that several wrk processes never share one.
write_batch_lua() {
  cat >"$1" <<'LUA'
-- thread_id is a global that setup() gives each thread (a local here would hide it).
local counter = 0
local next_thread = 0
function setup(thread)
  thread:set("thread_id", next_thread)
  next_thread = next_thread + 1
end
function init(args)
  campaign = args[1] or "load"
  prefix = args[2] or "t"
end
local rows = {}
for i = 1, 50 do
  rows[i] = string.format('{"joints":[%d,-90,90,0,90,0],"pose":{"position_mm":[%d.5,-120.25,640.75],' ..
                          '"quaternion":[1,0,0,0]}}', i, 300 + i)
end
local measurements = '"role":"calibration","measurements":[' .. table.concat(rows, ",") .. ']}'
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
function request()
  counter = counter + 1
  return wrk.format(nil, "/v1/campaigns/" .. campaign .. "/measurements", nil,
                    '{"request_id":"' .. prefix .. (thread_id or 0) .. '-' .. counter .. '",' .. measurements)
end
LUA
}

post_lua() {  # a wrk script that POSTs the JSON file $1 (printed)
  cat <<LUA
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
local f = io.open("$1")
wrk.body = f:read("*a")
f:close()
LUA
}
