#!/usr/bin/env bash
# What the shared job queue (Redis, --queue-url) costs and what replicas bring (docs/cluster.md).
#
#   bash bench/bench_cluster.sh
#
# 1. Per job: the same 10k-triangle job (BENCH_GRID x BENCH_GRID grid, 2 (n-1)^2 triangles, on an annulus
#    sector wound 1.25 turns) through POST /v1/jobs, one at a time, polled every 2 ms, result fetched: against
#    one `lipmap serve --workers 1` with the in-memory queue, and against one with --queue-url (a local Redis).
#    Median client time (submit to result in hand) and server time (created_at to finished_at) of BENCH_RUNS
#    jobs each after a warm-up; the difference is what Redis adds.
# 2. Throughput: BENCH_JOBS jobs of a smaller mesh (BENCH_SMALL_GRID) submitted at once: the in-memory queue
#    (one process, 1 worker), and the shared queue with 1 and with 2 replicas of 1 worker each, requests
#    spread over the replicas. Jobs per second from the first submission to the last result.
# Everything runs on 127.0.0.1. The machine's core count bounds what 2 replicas can gain: it is printed.
#
# Environment: LIPMAP_BUILD_DIR (build), BENCH_RUNS (15), BENCH_GRID (72: 10082 triangles), BENCH_SMALL_GRID
# (30), BENCH_JOBS (60).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build_dir="${LIPMAP_BUILD_DIR:-build}"
runs="${BENCH_RUNS:-15}"
grid="${BENCH_GRID:-72}"
small="${BENCH_SMALL_GRID:-30}"
njobs="${BENCH_JOBS:-60}"
lipmap="$build_dir/server/lipmap"
[[ -x "$lipmap" ]] || { echo "bench_cluster: build $lipmap first (cmake --build $build_dir --target lipmap)" >&2; exit 1; }
command -v redis-server >/dev/null && command -v node >/dev/null ||
  { echo "bench_cluster: needs redis-server and node (scripts/setup.sh --with-tests)" >&2; exit 1; }

work="$(mktemp -d)"
pids=()  # the replicas running now
redis_pid=""
stop_all() {
  local p
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  pids=()
}
cleanup() {
  stop_all
  [[ -z "$redis_pid" ]] || { kill -TERM "$redis_pid" 2>/dev/null; wait "$redis_pid" 2>/dev/null || true; }
  rm -rf "$work"
}
trap cleanup EXIT
free_port() { node -e 'const s=require("net").createServer();s.listen(0,"127.0.0.1",()=>{console.log(s.address().port);s.close()})'; }
wait_ready() { for _ in $(seq 100); do curl -sf "$1/readyz" >/dev/null && return 0; sleep 0.1; done; echo "no answer from $1" >&2; exit 1; }
serve() {  # serve [options]: starts a replica; its URL is in $url (not a subshell: the pid is kept)
  local port; port="$(free_port)"
  "$lipmap" serve --host 127.0.0.1 --port "$port" --workers 1 --queue 256 --log-level warn "$@" 2>>"$work/serve.log" &
  pids+=($!)
  url="http://127.0.0.1:$port"
  wait_ready "$url"
}

node tests/http/helpers/make_request.js grid "$grid" spiral >"$work/big.json"
node tests/http/helpers/make_request.js grid "$small" spiral >"$work/small.json"
faces="$(jq '.mesh.faces | length' "$work/big.json")"
redis_port="$(free_port)"
redis-server --port "$redis_port" --bind 127.0.0.1 --save '' --appendonly no --daemonize no --loglevel warning \
  >"$work/redis.log" 2>&1 &
redis_pid=$!
for _ in $(seq 50); do [[ "$(redis-cli -p "$redis_port" ping 2>/dev/null)" == PONG ]] && break; sleep 0.1; done
queue="redis://127.0.0.1:$redis_port"
drv() { node bench/cluster_driver.js "$@"; }

echo "machine: $(nproc) cores; lipmap $("$lipmap" --version 2>/dev/null | head -n 1)"
echo "== 1. per job, $faces triangles, median of $runs (one at a time, 1 worker)"
# Started one after the other (not side by side) so that the two never share the cores.
serve; drv latency "$url" "$work/big.json" 2 >/dev/null
memory="$(drv latency "$url" "$work/big.json" "$runs")"; stop_all
serve --queue-url "$queue"; drv latency "$url" "$work/big.json" 2 >/dev/null
shared="$(drv latency "$url" "$work/big.json" "$runs")"; stop_all
echo "in-memory queue:  $memory"
echo "shared (Redis):   $shared"
m="$(awk '{print $2}' <<<"$memory")" s="$(awk '{print $2}' <<<"$shared")"
awk -v m="$m" -v s="$s" 'BEGIN { printf "Redis adds %.1f ms per job (%.1f%%, client time)\n", s - m, 100 * (s - m) / m }'

echo "== 2. throughput: $njobs jobs of $(jq '.mesh.faces | length' "$work/small.json") triangles submitted at once"
serve; drv throughput "$url" "$work/small.json" 4 >/dev/null
mem1="$(drv throughput "$url" "$work/small.json" "$njobs")"; stop_all
redis-cli -p "$redis_port" flushall >/dev/null
serve --queue-url "$queue"; drv throughput "$url" "$work/small.json" 4 >/dev/null
one="$(drv throughput "$url" "$work/small.json" "$njobs")"; stop_all
redis-cli -p "$redis_port" flushall >/dev/null
serve --queue-url "$queue"; u1="$url"; serve --queue-url "$queue"; u2="$url"
drv throughput "$u1,$u2" "$work/small.json" 4 >/dev/null
two="$(drv throughput "$u1,$u2" "$work/small.json" "$njobs")"; stop_all
echo "in-memory, 1 process x 1 worker:  $mem1"
echo "shared, 1 replica x 1 worker:     $one"
echo "shared, 2 replicas x 1 worker:    $two"
awk -v a="$(awk '{print $2}' <<<"$one")" -v b="$(awk '{print $2}' <<<"$two")" -v m="$(awk '{print $2}' <<<"$mem1")" \
  'BEGIN { printf "2 replicas / 1 replica: %.2fx; 1 replica / in-memory: %.2fx\n", b / a, a / m }'
