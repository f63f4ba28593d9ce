#!/usr/bin/env bash
# A private PostgreSQL cluster for the tests: `pg_cluster.sh start DIR` runs initdb into a fresh directory under
# /tmp (so that the server's unprivileged user can reach it whatever the checkout's permissions), starts the
# server on a unix socket there with no TCP listener, and writes the socket directory to DIR/socket_dir;
# `pg_cluster.sh stop DIR` stops it and removes it. Run as root, the server runs as the unprivileged "postgres"
# user (PostgreSQL refuses root). fsync is off: the tests check robocal's transactions, not the disk, and the
# cluster is thrown away; benchmarks set PG_CLUSTER_FSYNC=on to measure with the durability a deployment has.
# Tests connect as "robocal" (trust authentication on the private socket only).
set -euo pipefail
command=${1:?usage: pg_cluster.sh start|stop DIR}
dir=${2:?usage: pg_cluster.sh start|stop DIR}

bin=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1)
if [ -z "$bin" ] || [ ! -x "$bin/initdb" ]; then
  echo "pg_cluster.sh: no PostgreSQL server found under /usr/lib/postgresql (deploy/install-deps.sh installs it)" >&2
  exit 1
fi
fsync=${PG_CLUSTER_FSYNC:-off}
case "$fsync" in on | off) ;; *) echo "pg_cluster.sh: PG_CLUSTER_FSYNC must be on or off" >&2; exit 2 ;; esac
as_server=()
if [ "$(id -u)" -eq 0 ]; then as_server=(runuser -u postgres --); fi

stop() {
  [ -f "$dir/socket_dir" ] || return 0
  local root
  root=$(cat "$dir/socket_dir")
  if [ -d "$root/data" ]; then
    "${as_server[@]}" "$bin/pg_ctl" -D "$root/data" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$root"
  rm -f "$dir/socket_dir"
}

case "$command" in
  start)
    mkdir -p "$dir"
    stop
    root=$(mktemp -d /tmp/robocal-pg.XXXXXX)
    chmod 0700 "$root"
    if [ ${#as_server[@]} -gt 0 ]; then chown postgres: "$root"; fi
    if ! "${as_server[@]}" "$bin/initdb" -D "$root/data" -U robocal --auth=trust --no-sync -E UTF8 --locale=C \
        >"$dir/initdb.log" 2>&1; then
      cat "$dir/initdb.log" >&2
      rm -rf "$root"
      exit 1
    fi
    if ! "${as_server[@]}" "$bin/pg_ctl" -D "$root/data" -l "$root/server.log" -w -t 60 \
        -o "-k $root -c listen_addresses='' -c fsync=$fsync -c full_page_writes=$fsync -c max_connections=300" \
        start >/dev/null; then
      cat "$root/server.log" >&2 || true
      rm -rf "$root"
      exit 1
    fi
    echo "$root" >"$dir/socket_dir"
    echo "pg_cluster.sh: PostgreSQL at unix socket $root"
    ;;
  stop)
    stop
    ;;
  *)
    echo "pg_cluster.sh: unknown command '$command' (start|stop)" >&2
    exit 2
    ;;
esac
