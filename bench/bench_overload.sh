#!/usr/bin/env bash
# Overload benchmark of `lipmap serve` (docs/hard-points.md keeps the figures).
#
#   bash bench/bench_overload.sh            (loads the machine: run it alone, e.g. under the build lock)
#
# 1. Capacity: a small mesh (BENCH_GRID x BENCH_GRID grid, harmonic maps) through POST /v1/parametrize by as
#    many closed-loop clients as workers, for BENCH_SECONDS: the jobs per second the service does when busy.
# 2. Overload at 2x and 5x: closed-loop clients numbering 2 and 5 times what the service holds at once
#    (workers + queue), each sending the same request again as soon as it has an answer, for BENCH_SECONDS.
#    Reported: the share of 200 and 503 (and any other status), 503s without Retry-After, useful jobs per
#    second (200s) against the capacity, the p99 of the 200s' latency, the latency of a /healthz probe every
#    0.5 s on the admin port and on the main port, and the RSS of the service before, at the peak and 30 s
#    after the overload.
# 3. Slow clients: BENCH_SLOW (500) connections each sending a header byte every 2 s for BENCH_SLOW_SECONDS
#    (60), reconnecting when cut; meanwhile a /healthz probe a second on the admin and the main port (1 s
#    timeout) and two loops of normal classify requests (10 s timeout). Reported: probes answered, share of
#    normal requests answered.
# Acceptance: only 200 and 503 (with Retry-After), useful >= 80% of capacity, /healthz within 1 s;
# slow clients: every admin probe answered, >= 90% of normal requests answered.
#
# Environment: LIPMAP_BUILD_DIR (build), BENCH_WORKERS (2), BENCH_QUEUE (4), BENCH_GRID (8), BENCH_SECONDS
# (20), BENCH_SLOW (500), BENCH_SLOW_SECONDS (60). Needs curl, jq and node (tests/http/helpers/make_request.js).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
lipmap="${LIPMAP_BUILD_DIR:-build}/server/lipmap"
workers="${BENCH_WORKERS:-2}"
queue="${BENCH_QUEUE:-4}"
grid="${BENCH_GRID:-8}"
seconds="${BENCH_SECONDS:-20}"
slow="${BENCH_SLOW:-500}"
slow_seconds="${BENCH_SLOW_SECONDS:-60}"
[[ -x "$lipmap" ]] || { echo "bench_overload: build $lipmap first" >&2; exit 1; }
for t in curl jq node; do command -v "$t" >/dev/null || { echo "bench_overload: $t is needed" >&2; exit 1; }; done

work="$(mktemp -d)"
server=""
cleanup() {
  jobs -p | xargs -r kill 2>/dev/null
  if [[ -n "$server" ]] && kill -0 "$server" 2>/dev/null; then kill -TERM "$server"; wait "$server" 2>/dev/null; fi
  rm -rf "$work"
}
trap cleanup EXIT

node tests/http/helpers/make_request.js grid "$grid" spiral >"$work/request.json"
node tests/http/helpers/make_request.js polygon spiral 64 >"$work/classify.json"

start_server() {  # start_server ARGS...: sets $server, $url, $admin
  "$lipmap" serve --host 127.0.0.1 --port 0 --admin-port 0 --log-level warn "$@" 2>"$work/serve.log" &
  server=$!
  local i line=""
  for i in $(seq 100); do
    line="$(grep -m1 '"event":"listening"' "$work/serve.log" 2>/dev/null || true)"
    [[ -n "$line" ]] && break
    sleep 0.1
  done
  [[ -n "$line" ]] || { echo "bench_overload: the service did not start" >&2; cat "$work/serve.log" >&2; exit 1; }
  url="http://127.0.0.1:$(jq -r .port <<<"$line")"
  admin="http://127.0.0.1:$(jq -r .admin_port <<<"$line")"
}
stop_server() { kill -TERM "$server"; wait "$server" 2>/dev/null; server=""; }
rss_mb() { awk '/^VmRSS/ {printf "%.0f", $2 / 1024}' "/proc/$server/status" 2>/dev/null; }
hwm_mb() { awk '/^VmHWM/ {printf "%.0f", $2 / 1024}' "/proc/$server/status" 2>/dev/null; }

# clients N SECONDS OUT: N closed-loop clients POSTing the mesh; one line per answer: status seconds retry-after
clients() {
  local n="$1" secs="$2" out="$3" i
  local until=$(($(date +%s) + secs))
  for i in $(seq "$n"); do
    (while [[ $(date +%s) -lt $until ]]; do
       curl -s -o /dev/null --max-time 30 -w '%{http_code} %{time_total} %header{retry-after}\n' \
         --json "@$work/request.json" "$url/v1/parametrize" || echo "000 30 -"
     done >"$out.$i") &
  done
  wait $(jobs -p | tail -n "$n")
  cat "$out".* >"$out"
}

# probe URL SECONDS OUT: a /healthz every 0.5 s with a 1 s timeout; one line per probe: status seconds
probe() {
  local until=$(($(date +%s) + $2))
  while [[ $(date +%s) -lt $until ]]; do
    curl -s -o /dev/null --max-time 1 -w '%{http_code} %{time_total}\n' "$1/healthz" || echo "000 1"
    sleep 0.5
  done >"$3"
}

p99() { awk '$1 == 200 {print $2}' "$1" | sort -n | awk '{a[NR] = $1} END {if (NR) {i = int(NR * 0.99); if (i < 1) i = 1; printf "%.0f", a[i] * 1000} else print "-"}'; }
probe_summary() { awk '{n++; if ($1 == 200) ok++; if ($2 > m) m = $2} END {printf "%d/%d answered 200, slowest %.0f ms", ok, n, m * 1000}' "$1"; }

echo "machine: $(nproc) cores; workers $workers, queue $queue, grid ${grid}x${grid}, ${seconds} s per phase"
start_server --workers "$workers" --queue "$queue"
clients "$workers" "$seconds" "$work/capacity" >/dev/null
capacity="$(awk -v s="$seconds" '$1 == 200 {n++} END {printf "%.1f", n / s}' "$work/capacity")"
echo "capacity: $capacity jobs/s with $workers clients (p99 $(p99 "$work/capacity") ms)"

for factor in 2 5; do
  n=$((factor * (workers + queue)))
  rss_before="$(rss_mb)"
  probe "$admin" "$seconds" "$work/probe_admin" &
  probe "$url" "$seconds" "$work/probe_main" &
  clients "$n" "$seconds" "$work/over$factor"
  wait
  peak="$(hwm_mb)"
  sleep 30
  rss_after="$(rss_mb)"
  awk -v f="$factor" -v n="$n" -v s="$seconds" -v cap="$capacity" '
    {t++; c[$1]++; if ($1 == 503 && ($3 == "" || $3 == "-")) bad++}
    END {
      other = t - c[200] - c[503]
      printf "overload %dx (%d clients): %d answers, 200 %.1f%%, 503 %.1f%%, other %d, 503 without Retry-After %d, useful %.1f jobs/s = %.0f%% of capacity\n",
        f, n, t, 100 * c[200] / t, 100 * c[503] / t, other, bad + 0, c[200] / s, 100 * c[200] / s / cap
    }' "$work/over$factor"
  echo "overload ${factor}x: p99 of the 200s $(p99 "$work/over$factor") ms; /healthz admin: $(probe_summary "$work/probe_admin"); main: $(probe_summary "$work/probe_main")"
  echo "overload ${factor}x: RSS before $rss_before MB, peak (VmHWM) $peak MB, 30 s after $rss_after MB"
done
stop_server

# 3. Slow clients (default --max-connections 512).
start_server --workers "$workers" --queue "$queue"
port="${url##*:}"
per=100
for g in $(seq $(((slow + per - 1) / per))); do
  timeout $((slow_seconds + 5)) bash -c '
    trap "" PIPE
    port=$1 n=$2 secs=$3
    fds=()
    for i in $(seq "$n"); do exec {fd}<>/dev/tcp/127.0.0.1/$port && fds+=("$fd"); done
    line="GET /healthz HTTP/1.1 X-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
    until=$(($(date +%s) + secs)); k=0
    while [[ $(date +%s) -lt $until ]]; do
      for idx in "${!fds[@]}"; do
        if ! printf "%s" "${line:$((k % ${#line})):1}" >&"${fds[$idx]}" 2>/dev/null; then
          old=${fds[$idx]}; exec {old}>&-
          exec {fd}<>/dev/tcp/127.0.0.1/$port 2>/dev/null && fds[$idx]=$fd
        fi
      done
      k=$((k + 1)); sleep 2
    done' _ "$port" "$per" "$slow_seconds" 2>/dev/null &
done
sleep 2
probe "$admin" "$((slow_seconds - 4))" "$work/slow_admin" &
probe "$url" "$((slow_seconds - 4))" "$work/slow_main" &
until=$(($(date +%s) + slow_seconds - 4))
for i in 1 2; do
  (while [[ $(date +%s) -lt $until ]]; do
     curl -s -o /dev/null --max-time 10 -w '%{http_code} %{time_total}\n' --json "@$work/classify.json" "$url/v1/polygons/classify" || echo "000 10"
     sleep 0.2
   done >"$work/slow_normal.$i") &
done
wait
cat "$work"/slow_normal.* >"$work/slow_normal"
echo "slow clients ($slow for ${slow_seconds} s): /healthz admin: $(probe_summary "$work/slow_admin"); main: $(probe_summary "$work/slow_main")"
awk '{n++; if ($1 == 200) ok++; else c[$1]++} END {printf "slow clients: normal requests answered 200: %d/%d = %.1f%%;", ok, n, 100 * ok / n; for (k in c) printf " %s: %d", k, c[k]; print ""}' "$work/slow_normal"
echo "slow clients: 408 answers $(curl -s "$admin/metrics" | awk '/^lipmap_http_requests_total/ && /status="408"/ {n += $2} END {print n + 0}'), connections refused $(grep -ac connection_refused "$work/serve.log")"
stop_server
