# Sourced by the scripts that start a robocal-server (server.sh here, tests/bench/bench_server.sh).
#
# read_listening_line FIFO: waits for the server's readiness signal, the first line of its stdout ("robocal-server
# listening on URL ..."), which it prints once its socket is bound, and prints the URL. The read blocks until the
# line is written or the server exits (end of file): an event, with no time limit that a busy machine could overrun
# (a server that hangs is the test runner's timeout's). The rest of stdout is drained to FIFO.out in the background,
# so that the server never blocks on a full pipe.
read_listening_line() {
  local fifo=$1 fd line=
  exec {fd}<"$fifo"
  IFS= read -r line <&"$fd" || true
  cat <&"$fd" >"$fifo.out" &
  exec {fd}<&-
  printf '%s\n' "$line" | sed -n 's/^robocal-server listening on \([^ ]*\).*/\1/p'
}
