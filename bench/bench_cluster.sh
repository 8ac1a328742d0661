#!/usr/bin/env bash
# What the shared job queue (Redis, --queue-url) costs and what replicas bring (docs/cluster.md). No
# assertions: it prints medians, ratios and SUMMARY lines (with the machine's load before and after).
#
#   bash bench/bench_cluster.sh        (under the build lock on a shared machine: nothing else running)
#
# Every replica has one worker (`--workers 1`): a replica is one core's worth, as the CPU request of 1 in
# docker/k8s reserves (its limit is 2), and the engine runs single-threaded (OpenBLAS is kept to one thread).
# 1. What Redis adds to a job: the same 10k-triangle job (BENCH_GRID x BENCH_GRID grid, 2 (n-1)^2 triangles,
#    an annulus sector wound 1.25 turns) on one process with the in-memory queue and on one replica with the
#    shared queue, one job at a time, the two interleaved (A B, B A, ...) over BENCH_RUNS pairs so that the
#    machine's drifting load falls on both alike. Medians of wall time (submit to result in hand, awaited
#    with long polls, GET /v1/jobs/{id}?wait=30) and server time (created_at to finished_at), and the median of the paired differences.
# 2. Jobs per second behind nginx: the in-memory queue (1 process), the shared queue with 1 replica and with 2
#    replicas (each pair of settings on its own Redis database, so that an idle replica takes nothing from the
#    other's queue). BENCH_ROUNDS rounds, each giving BENCH_JOBS jobs of the same size at once to each setting
#    in turn (order rotated each round); medians over the rounds, client and server side.
# 0. The machine's own ceiling, with no HTTP, Redis or nginx: BENCH_CEILING runs of the same job by the CLI
#    (`lipmap map`), one after the other and then as two streams side by side; 2 replicas cannot gain more.
# Everything runs on 127.0.0.1; the machine's core count bounds what 2 replicas can gain: it is printed.
#
# Environment: LIPMAP_BUILD_DIR (build), BENCH_RUNS (40 pairs), BENCH_GRID (72: 10082 triangles),
# BENCH_JOBS (24), BENCH_ROUNDS (5), BENCH_CEILING (8), BENCH_PARTS (the parts to run: "0 1 2").
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build_dir="${LIPMAP_BUILD_DIR:-build}"
runs="${BENCH_RUNS:-40}"
grid="${BENCH_GRID:-72}"
njobs="${BENCH_JOBS:-24}"
rounds="${BENCH_ROUNDS:-5}"
ceiling="${BENCH_CEILING:-8}"
parts=" ${BENCH_PARTS:-0 1 2} "
lipmap="$build_dir/server/lipmap"
[[ -x "$lipmap" ]] || { echo "bench_cluster: build $lipmap first (cmake --build $build_dir --target lipmap)" >&2; exit 1; }
nginx="$(command -v nginx || echo /usr/sbin/nginx)"
command -v redis-server >/dev/null && command -v node >/dev/null && [[ -x "$nginx" ]] ||
  { echo "bench_cluster: needs redis-server, nginx and node (scripts/setup.sh --with-tests)" >&2; exit 1; }

work="$(mktemp -d)"
pids=()
cleanup() {
  local p
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
free_port() { node -e 'const s=require("net").createServer();s.listen(0,"127.0.0.1",()=>{console.log(s.address().port);s.close()})'; }
wait_ready() { for _ in $(seq 100); do curl -sf "$1/readyz" >/dev/null && return 0; sleep 0.1; done; echo "no answer from $1" >&2; exit 1; }
serve() {  # serve VAR [options]: starts a one-worker process; its port in $VAR
  local var="$1" port; shift
  port="$(free_port)"
  "$lipmap" serve --host 127.0.0.1 --port "$port" --workers 1 --queue 256 --log-level warn "$@" 2>>"$work/serve.log" &
  pids+=($!)
  wait_ready "http://127.0.0.1:$port"
  printf -v "$var" '%s' "$port"
}
load() { echo "load: $(uptime | sed 's/.*load average/load average/')"; }

node tests/http/helpers/make_request.js grid "$grid" spiral >"$work/job.json"
faces="$(jq '.mesh.faces | length' "$work/job.json")"
redis_port="$(free_port)"
redis-server --port "$redis_port" --bind 127.0.0.1 --save '' --appendonly no --daemonize no --loglevel warning \
  >"$work/redis.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [[ "$(redis-cli -p "$redis_port" ping 2>/dev/null)" == PONG ]] && break; sleep 0.1; done

serve mem
serve one --queue-url "redis://127.0.0.1:$redis_port/0"
serve two_a --queue-url "redis://127.0.0.1:$redis_port/1"
serve two_b --queue-url "redis://127.0.0.1:$redis_port/1"
nginx_mem="$(free_port)" nginx_one="$(free_port)" nginx_two="$(free_port)"
mkdir -p "$work/nginx"
cat >"$work/nginx/nginx.conf" <<CONF
daemon off;
$([[ "$(id -u)" == 0 ]] && echo "user root root;")
worker_processes 1;
pid $work/nginx/nginx.pid;
error_log $work/nginx/error.log warn;
events { worker_connections 1024; }
http {
  access_log off;
  client_body_temp_path $work/nginx/body;
  proxy_temp_path $work/nginx/proxy;
  client_max_body_size 256m;
  proxy_http_version 1.1;
  proxy_set_header Connection "";
  upstream mem { server 127.0.0.1:$mem; keepalive 16; }
  upstream one { server 127.0.0.1:$one; keepalive 16; }
  upstream two { server 127.0.0.1:$two_a; server 127.0.0.1:$two_b; keepalive 16; }
  server { listen 127.0.0.1:$nginx_mem; location / { proxy_pass http://mem; } }
  server { listen 127.0.0.1:$nginx_one; location / { proxy_pass http://one; } }
  server { listen 127.0.0.1:$nginx_two; location / { proxy_pass http://two; } }
}
CONF
"$nginx" -p "$work/nginx" -c "$work/nginx/nginx.conf" -e "$work/nginx/error.log" &
pids+=($!)
wait_ready "http://127.0.0.1:$nginx_two"
drv() { node bench/cluster_driver.js "$@"; }

echo "machine: $(nproc) cores; lipmap $("$lipmap" --version 2>/dev/null | head -n 1); every process 1 worker"
if [[ "$parts" == *" 0 "* ]]; then
  echo "== 0. the machine's ceiling: $ceiling CLI runs of the job, one after the other, then 2 streams side by side"
  load
  stream() { local i; for i in $(seq "$1"); do "$lipmap" map "$work/job.json" -o "$work/cli$2.json" >/dev/null; done; }
  stream 1 a  # warm-up
  t0=$(date +%s.%N); stream "$ceiling" a; t1=$(date +%s.%N)
  stream $((ceiling / 2)) a & p1=$!; stream $((ceiling / 2)) b & p2=$!; wait "$p1" "$p2"; t2=$(date +%s.%N)
  awk -v t0="$t0" -v t1="$t1" -v t2="$t2" -v n="$ceiling" 'BEGIN { s = t1 - t0; p = t2 - t1
    printf "SUMMARY ceiling: 1 stream %.2f runs/s, 2 streams %.2f runs/s: %.2fx\n", n / s, n / p, s / p }'
  load
fi
[[ "$parts" == *" 1 "* ]] && {
echo "== 1. what Redis adds to a job of $faces triangles: $runs interleaved pairs, one job at a time"
load
drv ab "$work/job.json" 2 in-memory="http://127.0.0.1:$mem" redis="http://127.0.0.1:$one" >/dev/null  # warm-up
drv ab "$work/job.json" "$runs" in-memory="http://127.0.0.1:$mem" redis="http://127.0.0.1:$one"
load
}
[[ "$parts" == *" 2 "* ]] && {
echo "== 2. jobs per second behind nginx: $rounds rounds of $njobs jobs of $faces triangles submitted at once"
drv throughput "$work/job.json" "$njobs" "$rounds" in-memory-1="http://127.0.0.1:$nginx_mem" \
  redis-1-replica="http://127.0.0.1:$nginx_one" redis-2-replicas="http://127.0.0.1:$nginx_two"
load
}
exit 0
