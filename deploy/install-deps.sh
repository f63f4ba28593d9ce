#!/usr/bin/env bash
# Installs the Debian packages robocal builds, tests and runs with.
# Idempotent and quick: asks dpkg what is missing and only then runs apt-get (update once, then install).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libcpp-httplib-dev libsqlite3-dev libssl-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  curl jq sqlite3 openssl
  # The replies of the curl harness and the docs' examples checked against api/openapi.json.
  python3 python3-jsonschema
  # make test-sanitize and make fuzz: clang, and its sanitizer and libFuzzer runtimes (libclang_rt.*).
  clang libclang-rt-14-dev
  # URDF import and export (POST /v1/robots with "urdf").
  liburdfdom-dev libtinyxml-dev libtinyxml2-dev
  # The campaign report's browser test: headless Chromium renders GET /v1/campaigns/{c}/report to PNG.
  chromium
  # The PostgreSQL storage (--db postgresql://...): libpq to build with; the server for the tests, which start
  # a private cluster of their own (tests/storage/pg_cluster.sh).
  libpq-dev postgresql
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
# Installing the PostgreSQL server would create and start a system-wide cluster; robocal's tests start their
# own and a deployment configures its database itself (docs/scaling.md), so none is created here.
if [[ " ${missing[*]} " == *" postgresql "* ]] && [ ! -e /etc/postgresql-common/createcluster.d/robocal.conf ]; then
  "${sudo_cmd[@]}" mkdir -p /etc/postgresql-common/createcluster.d
  echo "create_main_cluster = false" | "${sudo_cmd[@]}" tee /etc/postgresql-common/createcluster.d/robocal.conf >/dev/null
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
