#!/usr/bin/env bash
# HTTP service benchmark: what the service adds to a job, and how throughput scales with workers.
#
#   bash bench/bench_http.sh
#
# 1. For each size of BENCH_GRIDS (default 72 355: 10k and 250k triangles), the same job (a GRID x GRID-vertex
#    grid, 2 (n-1)^2 triangles, mapped onto an annulus sector
#    wound 1.25 turns, harmonic maps) through `lipmap map REQUEST.json -o OUT.json` and through
#    `curl --json @REQUEST.json /v1/parametrize` against `lipmap serve --workers 1`, alternating, BENCH_RUNS
#    times each after a warm-up; wall time per call (process start, reading, mapping, writing / the whole
#    HTTP exchange), median of each, and their ratio; and what HTTP adds to the engine's own total (wall time
#    of the call minus the engine's total in the answer's Server-Timing header, which is
#    diagnostics.timings_ms.total), in seconds and in percent. In the timed calls curl receives the answer and
#    discards it (-o /dev/null), as a client that reads the answer into memory: writing 17.8 MB to a file is
#    the client's work, not HTTP's (10-15 ms here). The warm-up answers of both are compared (up to timings) to
#    show it is the same job. The 250k job runs BENCH_LARGE_RUNS (5) times (its engine time alone varies by
#    10-20 % from run to run here).
# 2. Jobs per second for a small mesh (BENCH_SMALL_GRID, default 10: 162 triangles) through POST
#    /v1/parametrize with 1 and with 2 workers: wrk on loopback (one thread, BENCH_CONNECTIONS connections,
#    BENCH_DURATION), every answer 200.
# Everything runs on 127.0.0.1. Needs node (tests/http/helpers/make_request.js writes the requests) and wrk
# (scripts/setup.sh --with-bench installs it).
#
# Environment: LIPMAP_BUILD_DIR (default build), LIPMAP_JOBS (2), BENCH_RUNS (7), BENCH_GRIDS ("72 355": 10082
# and 250632 triangles), BENCH_LARGE_RUNS (5, for grids above 200), BENCH_SMALL_GRID (10), BENCH_DURATION
# (10s), BENCH_CONNECTIONS (8).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build_dir="${LIPMAP_BUILD_DIR:-build}"
jobs="${LIPMAP_JOBS:-2}"
runs="${BENCH_RUNS:-7}"
grids="${BENCH_GRIDS:-${BENCH_GRID:-72 355}}"
large_runs="${BENCH_LARGE_RUNS:-5}"
small="${BENCH_SMALL_GRID:-10}"
duration="${BENCH_DURATION:-10s}"
connections="${BENCH_CONNECTIONS:-8}"

bash scripts/setup.sh --with-bench
command -v node >/dev/null || { echo "bench_http: node is needed to write the requests (scripts/test.sh installs it)" >&2; exit 1; }
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null
cmake --build "$build_dir" -j "$jobs" --target lipmap >/dev/null
lipmap="$build_dir/server/lipmap"

work="$(mktemp -d)"
server=""
cleanup() {
  if [[ -n "$server" ]] && kill -0 "$server" 2>/dev/null; then kill -TERM "$server"; wait "$server" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

start_server() {  # start_server WORKERS: sets $server and $url
  "$lipmap" serve --host 127.0.0.1 --port 0 --workers "$1" --queue 256 --log-level warn 2>"$work/serve.log" &
  server=$!
  local port="" i
  # the listening line is logged at info level: read the port from the socket table instead
  for i in $(seq 100); do
    port="$(ss -ltnpH 2>/dev/null | grep "pid=$server," | sed -E 's/.*127\.0\.0\.1:([0-9]+).*/\1/' | head -n 1 || true)"
    [[ -n "$port" ]] && break
    sleep 0.1
  done
  [[ -n "$port" ]] || { echo "bench_http: the service did not start" >&2; cat "$work/serve.log" >&2; exit 1; }
  url="http://127.0.0.1:$port"
}
stop_server() {
  kill -TERM "$server"
  wait "$server" || true
  server=""
}
median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
now_ns() { date +%s%N; }

cpu="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
mem="$(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)"
echo "machine: $(nproc) cores, $cpu, $mem, $(uname -sr); load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

# ---- 1. the same job: HTTP vs CLI ------------------------------------------------------------------------
same_job() {  # same_job GRID RUNS
local grid="$1" runs="$2"
node tests/http/helpers/make_request.js grid "$grid" spiral --method harmonic >"$work/job.json"
triangles=$((2 * (grid - 1) * (grid - 1)))
echo "job: ${grid}x${grid} grid, $triangles triangles, onto a 1.25-turn annulus sector, harmonic; $(wc -c <"$work/job.json") bytes of request"
start_server 1
# warm-up (page cache, allocator, CHOLMOD's first call); these two answers are the ones compared
"$lipmap" map "$work/job.json" -o "$work/cli.json"
curl -sS -o "$work/http.json" --json "@$work/job.json" "$url/v1/parametrize"
same="no"
if [[ "$(jq -c 'del(.diagnostics.timings_ms)' "$work/cli.json")" == "$(jq -c 'del(.diagnostics.timings_ms)' "$work/http.json")" ]]; then same="yes"; fi
answer_bytes="$(wc -c <"$work/http.json")"
: >"$work/cli.times"
: >"$work/http.times"
: >"$work/cli.engine"
: >"$work/http.engine"
: >"$work/http.added"
for i in $(seq "$runs"); do
  t0=$(now_ns)
  "$lipmap" map "$work/job.json" -o "$work/cli.out.json"
  t1=$(now_ns)
  echo "scale=6; ($t1 - $t0) / 1000000000" | bc >>"$work/cli.times"
  jq '.diagnostics.timings_ms.total / 1000' "$work/cli.out.json" >>"$work/cli.engine"
  code="$(curl -sS -o /dev/null -D "$work/http.headers" -w '%{http_code} %{time_total}' --json "@$work/job.json" "$url/v1/parametrize")"
  [[ "${code%% *}" == 200 ]] || { echo "bench_http: HTTP ${code%% *}: $(cat "$work/http.headers")" >&2; exit 1; }
  echo "${code#* }" >>"$work/http.times"
  # what HTTP adds to this very call: its wall time minus the engine's own total (Server-Timing: engine;dur=MS)
  engine="$(tr -d '\r' <"$work/http.headers" | sed -nE 's/^[Ss]erver-[Tt]iming:.*engine;dur=([0-9.]+).*/\1/p')"
  [[ -n "$engine" ]] || { echo "bench_http: no engine time in Server-Timing: $(cat "$work/http.headers")" >&2; exit 1; }
  echo "${code#* } $engine" | awk '{print $1 - $2 / 1000}' >>"$work/http.added"
  echo "$engine" | awk '{print $1 / 1000}' >>"$work/http.engine"
done
stop_server
cli_median="$(median <"$work/cli.times")"
http_median="$(median <"$work/http.times")"
engine_ms="$(echo "1000 * $(median <"$work/http.engine")" | bc -l)"
ratio="$(echo "scale=4; $http_median / $cli_median" | bc)"
printf 'same job, %d runs each (median wall time): lipmap map %.3f s, HTTP %.3f s, ratio HTTP/CLI %.3f (%+.1f%%); engine total (median) %.0f ms; answer %d bytes; identical answers: %s\n' \
  "$runs" "$cli_median" "$http_median" "$ratio" "$(echo "($ratio - 1) * 100" | bc -l)" "$engine_ms" "$answer_bytes" "$same"
http_added="$(median <"$work/http.added")"
http_engine="$(median <"$work/http.engine")"
cli_engine="$(median <"$work/cli.engine")"
printf 'what HTTP adds (wall time of the call minus the engine total in its Server-Timing, median): %.3f s on an engine median of %.3f s = %+.1f%%; lipmap map adds %.3f s (process start, file reading and writing) to %.3f s\n' \
  "$http_added" "$http_engine" "$(echo "100 * $http_added / $http_engine" | bc -l)" "$(echo "$cli_median - $cli_engine" | bc -l)" "$cli_engine"
echo "  cli:  $(tr '\n' ' ' <"$work/cli.times")"
echo "  http: $(tr '\n' ' ' <"$work/http.times")"
printf 'summary: %d triangles: HTTP adds %.1f%% to the engine (%.3f s on %.3f s)\n' "$triangles" \
  "$(echo "100 * $http_added / $http_engine" | bc -l)" "$http_added" "$http_engine"
}
for g in $grids; do
  if (( g > 200 )); then same_job "$g" "$large_runs"; else same_job "$g" "$runs"; fi
done

# ---- 2. jobs per second, 1 and 2 workers --------------------------------------------------------------------
node tests/http/helpers/make_request.js grid "$small" spiral --method harmonic >"$work/small.json"
cat >"$work/post.lua" <<EOF
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
local f = io.open("$work/small.json", "rb")
wrk.body = f:read("*a")
f:close()
EOF
declare -A rate
for w in 1 2; do
  start_server "$w"
  curl -sS -o /dev/null --json "@$work/small.json" "$url/v1/parametrize"  # warm-up
  cpu0="$(awk '{print $14 + $15}' "/proc/$server/stat")"
  for t in /proc/"$server"/task/*; do echo "${t##*/} $(cat "$t/schedstat")"; done | sort >"$work/sched0"
  wrk -t1 -c"$connections" -d"$duration" --latency -s "$work/post.lua" "$url/v1/parametrize" >"$work/wrk.$w"
  for t in /proc/"$server"/task/*; do echo "${t##*/} $(cat "$t/schedstat")"; done | sort >"$work/sched1"
  cpu1="$(awk '{print $14 + $15}' "/proc/$server/stat")"
  # per busy thread (the workers): time on a CPU and time runnable but waiting for one (schedstat, ns)
  sched="$(join "$work/sched0" "$work/sched1" | awk '{run = ($5 - $2) / 1e9; wait = ($6 - $3) / 1e9;
    if (run > 0.2) { n++; r += run; q += wait } } END { printf "%d busy threads: %.1f s on a CPU, %.1f s runnable but waiting for one", n, r, q }')"
  cpu_s="$(echo "scale=2; ($cpu1 - $cpu0) / $(getconf CLK_TCK)" | bc)"
  stop_server
  if grep -q 'Non-2xx' "$work/wrk.$w"; then echo "bench_http: non-2xx answers with $w workers:" >&2; cat "$work/wrk.$w" >&2; exit 1; fi
  rate[$w]="$(awk '/Requests\/sec/ {print $2}' "$work/wrk.$w")"
  p50="$(awk '/ 50%/ {print $2}' "$work/wrk.$w")"
  p99="$(awk '/ 99%/ {print $2}' "$work/wrk.$w")"
  jobs_done="$(awk '/requests in/ {print $1}' "$work/wrk.$w")"
  echo "small jobs ($((2 * (small - 1) * (small - 1))) triangles), $w worker(s), $connections connections, $duration: ${rate[$w]} jobs/s (latency p50 $p50, p99 $p99); the service used $cpu_s CPU-s for $jobs_done jobs: $(echo "scale=1; $jobs_done / $cpu_s" | bc) jobs per CPU-second; $sched"
done
printf 'scaling 2 workers / 1 worker: %.2fx\n' "$(echo "${rate[2]} / ${rate[1]}" | bc -l)"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg) (a load above nproc means other processes take cores from the workers:"
echo "  then the workers' runnable-but-waiting time, not a lock, bounds the scaling)"
