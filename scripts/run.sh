#!/usr/bin/env bash
# The run command (README): installs what is missing, builds lipmap into build/ (Release, ccache), starts
# the HTTP service on 127.0.0.1, shows it answering (health, a polygon classified, a mesh mapped, a job
# submitted and polled) and then keeps serving in the foreground until Ctrl-C (SIGINT) or SIGTERM, on
# which it drains and exits 0.
#
#   bash scripts/run.sh [POLYGON.json]     # POLYGON.json: a classify body to show instead of the bundled one
#
# Environment: LIPMAP_BUILD_DIR (default build), LIPMAP_JOBS (default 2), LIPMAP_PORT (default 8080), and
# any other LIPMAP_* setting of `lipmap serve --help` (LIPMAP_WORKERS, LIPMAP_DEADLINE, ...).
# The service listens on 127.0.0.1 only; set LIPMAP_HOST to change that deliberately.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build_dir="${LIPMAP_BUILD_DIR:-build}"
jobs="${LIPMAP_JOBS:-2}"
# ccache keys on paths relative to the checkout, so that every clone of the repository shares one cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
export LIPMAP_HOST="${LIPMAP_HOST:-127.0.0.1}"
export LIPMAP_PORT="${LIPMAP_PORT:-8080}"
# The lipmap binary sets its own malloc settings (huge pages, fixed thresholds: server/app/main.cpp), so
# GLIBC_TUNABLES is not set here for the whole script (apt and the compilers).
polygon="${1:-tests/data/polygons/spiral_overlapping.json}"
mesh_request="tests/data/requests/grid8_spiral.json"

bash scripts/setup.sh
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >&2
cmake --build "$build_dir" -j "$jobs" --target lipmap >&2

url="http://$LIPMAP_HOST:$LIPMAP_PORT"
echo "== lipmap serve on $url (logs: one JSON line per request on stderr)" >&2
# Its own session, so that a Ctrl-C reaches it once, through the trap below, and not twice (a second signal
# makes the service cancel in-flight work instead of letting it finish).
setsid "$build_dir/server/lipmap" serve &
server=$!
# Ctrl-C / SIGTERM: the service drains and exits 0; this script then exits with it. Any other way out of
# this script (a failed step below) stops the service too, so that it never stays behind holding the port.
trap 'kill -TERM "$server" 2>/dev/null || true' INT TERM
trap 'if kill -0 "$server" 2>/dev/null; then kill -TERM "$server"; wait "$server" 2>/dev/null || true; fi' EXIT

ready=""
for _ in $(seq 100); do
  if curl -fsS "$url/readyz" >/dev/null 2>&1; then ready=1; break; fi
  kill -0 "$server" 2>/dev/null || break
  sleep 0.1
done
if [[ -z "$ready" ]]; then
  echo "run: the service did not come up on $url (port in use? set LIPMAP_PORT)" >&2
  kill -TERM "$server" 2>/dev/null || true
  wait "$server" || true
  exit 1
fi

show() {  # show DESCRIPTION CURL-ARGS...: prints the command and the first part of its answer
  local what="$1" answer; shift
  echo >&2
  echo "\$ curl $*"
  # The whole answer first, then its head: a pipe into `head` would make curl fail (exit 23) when head
  # closes it early, and under pipefail that ended the script.
  answer="$(curl -sS "$@")"
  printf '%s\n' "${answer:0:700}"
}
show "liveness" "$url/healthz"
show "classify" --json "@$polygon" "$url/v1/polygons/classify"
show "map" --json "@$mesh_request" "$url/v1/parametrize"
job="$(curl -sS --json "@$mesh_request" "$url/v1/jobs")"
echo >&2
echo "\$ curl --json @$mesh_request $url/v1/jobs"
echo "$job"
id="$(sed -E 's/.*"id":"([0-9a-f]+)".*/\1/' <<<"$job")"
for _ in $(seq 50); do
  state="$(curl -sS "$url/v1/jobs/$id" | sed -E 's/.*"state":"([a-z]+)".*/\1/')"
  [[ "$state" == queued || "$state" == running ]] || break
  sleep 0.1
done
show "job" "$url/v1/jobs/$id"
echo >&2
echo "== serving on $url until Ctrl-C (API: $url/v1/openapi.json, metrics: $url/metrics)" >&2
set +e
wait "$server"
status=$?
# a signal that reached this script first: wait again for the drain to finish
if kill -0 "$server" 2>/dev/null; then wait "$server"; status=$?; fi
exit "$status"
