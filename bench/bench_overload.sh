#!/usr/bin/env bash
# Overload benchmark of `lipmap serve` (docs/hard-points.md keeps the figures).
#
#   bash bench/bench_overload.sh            (loads the machine: run it alone, e.g. under the build lock)
#
# For each mesh of BENCH_GRIDS (default "8 64": a 98-triangle grid and a 7,938-triangle grid mapped onto a
# spiral, harmonic maps), against `lipmap serve --workers BENCH_WORKERS --queue BENCH_QUEUE --admin-port 0`:
# 1. Capacity: workers + queue closed-loop clients (each sends again as soon as it has an answer: the queue is
#    never empty and never over-full) POST /v1/parametrize for BENCH_SECONDS; capacity = 200s per second.
# 2. Overload at 2x and 5x capacity: an open loop offering 2 and 5 times the capacity in requests per second
#    for BENCH_SECONDS (the offered load stays, however slowly the service answers). Reported: the share of
#    200 and 503 and any other status, 503s without Retry-After, useful jobs per second (200s) and their ratio
#    to the capacity, median and p99 latency of the 200s and of the 503s, a /healthz probe every 0.5 s (1 s
#    timeout) on the admin and on the main port (answered, median, slowest), and the RSS of the service before,
#    at the peak (sampled every 0.5 s) and 30 s after.
# 3. Slow clients: BENCH_SLOW (500) connections each sending one byte of a request head every 2 s for
#    BENCH_SLOW_SECONDS (60), reconnecting when cut (the service answers 408 after --header-timeout, 10 s);
#    meanwhile a /healthz probe every 0.5 s on the admin and on the main port (1 s timeout) and two loops of
#    normal classify requests (10 s timeout). Reported: probes answered, share of normal requests answered.
# The last lines ("summary:") hold each figure against the acceptance of the overload work: only 200 and 503
# (with Retry-After), useful >= 80% of capacity, every /healthz within 1 s; slow clients: every health probe
# answered, >= 90% of normal requests answered. It reports; it asserts nothing.
#
# The load comes from one node process (bench/overload_driver.js), not a curl per request: hundreds of
# processes a second would dominate. On a machine with few cores the load generator's CPU would come out of the
# service it measures (at 5x on the small mesh the driver alone takes a good part of a core), so by default
# (BENCH_PIN=auto, 2 cores or more and taskset present) the service runs on core 0 with one worker and the
# driver, the probes and curl on core 1: capacity and overload are then the same one core's worth, and every
# refusal's cost, accept, head and body read included, is taken from that core. BENCH_PIN=no shares all cores
# (then BENCH_WORKERS defaults to 2). Each phase also prints the service's CPU time per answer.
#
# Environment: LIPMAP_BUILD_DIR (build), BENCH_PIN (auto), BENCH_WORKERS (1 pinned, else 2), BENCH_QUEUE (4),
# BENCH_GRIDS ("8 64"), BENCH_SECONDS
# (20), BENCH_SETTLE (30: seconds before the RSS "after"), BENCH_SLOW (500), BENCH_SLOW_SECONDS (60). Needs
# curl, jq and node (tests/http/helpers/make_request.js writes the requests).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
lipmap="${LIPMAP_BUILD_DIR:-build}/server/lipmap"
pin="${BENCH_PIN:-auto}"
if [[ "$pin" == auto ]]; then
  if (($(nproc) >= 2)) && command -v taskset >/dev/null; then pin=yes; else pin=no; fi
fi
service_cpu=() client_cpu=()
if [[ "$pin" == yes ]]; then
  service_cpu=(taskset -c 0)
  client_cpu=(taskset -c 1)
  workers="${BENCH_WORKERS:-1}"
else
  workers="${BENCH_WORKERS:-2}"
fi
queue="${BENCH_QUEUE:-4}"
grids="${BENCH_GRIDS:-8 64}"
seconds="${BENCH_SECONDS:-20}"
settle="${BENCH_SETTLE:-30}"
slow="${BENCH_SLOW:-500}"
slow_seconds="${BENCH_SLOW_SECONDS:-60}"
[[ -x "$lipmap" ]] || { echo "bench_overload: build $lipmap first" >&2; exit 1; }
for t in curl jq node; do command -v "$t" >/dev/null || { echo "bench_overload: $t is needed" >&2; exit 1; }; done

work="$(mktemp -d)"
server=""
cleanup() {
  local p
  for p in $(jobs -p); do kill "$p" 2>/dev/null; done
  if [[ -n "$server" ]] && kill -0 "$server" 2>/dev/null; then kill -TERM "$server"; wait "$server" 2>/dev/null; fi
  rm -rf "$work"
}
trap cleanup EXIT

start_server() {  # start_server ARGS...: sets $server, $url, $admin (the "listening" line is logged at any level)
  "${service_cpu[@]}" "$lipmap" serve --host 127.0.0.1 --port 0 --admin-port 0 --log-level warn "$@" 2>"$work/serve.log" &
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
# cpu_ticks: the service's user + system CPU time so far, in clock ticks
cpu_ticks() { awk '{print $14 + $15}' "/proc/$server/stat" 2>/dev/null || echo 0; }
rss_mb() { awk '/^VmRSS/ {printf "%.0f", $2 / 1024}' "/proc/$server/status" 2>/dev/null; }

# probe URL SECONDS OUT: a /healthz every 0.5 s with a 1 s timeout; one line per probe: status seconds
probe() {
  local until=$(($(date +%s) + $2))
  while [[ $(date +%s) -lt $until ]]; do
    # curl prints its -w line on a timeout too (status 000): one line per probe
    "${client_cpu[@]}" curl -s -o /dev/null --max-time 1 -w '%{http_code} %{time_total}\n' "$1/healthz" || true
    sleep 0.5
  done >"$3"
}
# rss_peak SECONDS OUT: the largest VmRSS (MB) seen every 0.5 s
rss_peak() {
  local until=$(($(date +%s) + $1)) peak=0 r
  while [[ $(date +%s) -lt $until ]]; do
    r="$(rss_mb)"; [[ -n "$r" ]] && ((r > peak)) && peak=$r
    sleep 0.5
  done
  echo "$peak" >"$2"
}

# quantile Q FILE STATUS: the Q-quantile (ms) of the latencies (column 2, ms) of the answers with STATUS
quantile() {
  awk -v s="$3" '$1 == s {print $2}' "$2" | sort -g |
    awk -v q="$1" '{a[NR] = $1} END {if (NR) {i = int(NR * q + 0.999999); if (i < 1) i = 1; if (i > NR) i = NR; printf "%.1f", a[i]} else printf "-"}'
}
# probe_summary FILE: "answered/probes, median M ms, slowest S ms" (probe files hold seconds)
probe_summary() {
  sort -k2,2g "$1" | awk '{n++; t[n] = $2 * 1000; if ($1 == 200) ok++} END {
    if (!n) {printf "no probe"; exit}
    printf "%d/%d answered 200, median %.1f ms, slowest %.1f ms", ok, n, t[int((n + 1) / 2)], t[n]}'
}
probe_ok() {  # probe_ok FILE: "yes" when every probe answered 200 within 1 s
  awk '{n++; if ($1 != 200 || $2 > 1) bad++} END {print (n && !bad) ? "yes" : "no"}' "$1"
}

echo "bench_overload: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); workers $workers, queue $queue, ${seconds} s per phase;" \
  "$([[ "$pin" == yes ]] && echo "service pinned to core 0, load generator and probes to core 1" || echo "service and load generator share the cores")"
hz="$(getconf CLK_TCK)"
summary=()
for grid in $grids; do
  node tests/http/helpers/make_request.js grid "$grid" spiral >"$work/request.json"
  tris=$((2 * (grid - 1) * (grid - 1)))
  start_server --workers "$workers" --queue "$queue"
  # warm-up: the first jobs pay for page faults and lazy initialization
  "${client_cpu[@]}" node bench/overload_driver.js closed "$url" "$work/request.json" "$workers" 2 >/dev/null
  ticks="$(cpu_ticks)"
  "${client_cpu[@]}" node bench/overload_driver.js closed "$url" "$work/request.json" $((workers + queue)) "$seconds" >"$work/capacity"
  ticks=$(($(cpu_ticks) - ticks))
  capacity="$(awk -v s="$seconds" '$1 == 200 {n++} END {printf "%.1f", n / s}' "$work/capacity")"
  echo "grid ${grid} (${tris} triangles) capacity: $capacity jobs/s with $((workers + queue)) closed-loop clients;" \
    "service CPU $(awk -v t="$ticks" -v hz="$hz" -v s="$seconds" -v n="$(wc -l <"$work/capacity")" \
      'BEGIN {printf "%.2f cores, %.2f ms per answer", t / hz / s, n ? 1000 * t / hz / n : 0}');" \
    "200s: median $(quantile 0.5 "$work/capacity" 200) ms, p99 $(quantile 0.99 "$work/capacity" 200) ms;" \
    "other answers $(awk '$1 != 200' "$work/capacity" | wc -l)"
  for factor in 2 5; do
    rate="$(awk -v c="$capacity" -v f="$factor" 'BEGIN {printf "%.0f", c * f}')"
    rss_before="$(rss_mb)"
    # (a bare `wait` would wait for the service too: it is a child of this shell)
    probe "$admin" "$seconds" "$work/probe_admin" &
    helpers=($!)
    probe "$url" "$seconds" "$work/probe_main" &
    helpers+=($!)
    rss_peak "$seconds" "$work/peak" &
    helpers+=($!)
    load="$(cut -d' ' -f1 /proc/loadavg)"
    ticks="$(cpu_ticks)"
    "${client_cpu[@]}" node bench/overload_driver.js open "$url" "$work/request.json" "$rate" "$seconds" >"$work/over"
    ticks=$(($(cpu_ticks) - ticks))
    wait "${helpers[@]}"
    sleep "$settle"
    rss_after="$(rss_mb)"
    out="$(awk -v s="$seconds" -v cap="$capacity" '
      {t++; c[$1]++; if ($1 == 503 && ($3 == "" || $3 == "-")) bad++}
      END {
        other = t - c[200] - c[503]
        printf "%d answers, 200 %.1f%%, 503 %.1f%%, other %d, 503 without Retry-After %d, useful %.1f jobs/s = %.0f%% of capacity\n",
          t, 100 * c[200] / t, 100 * c[503] / t, other, bad + 0, c[200] / s, 100 * c[200] / s / cap
        printf "%s %d %d %.0f\n", (other == 0 && bad == 0) ? "yes" : "no", other, bad + 0, 100 * c[200] / s / cap
      }' "$work/over")"
    read -r only_ok other bad ratio <<<"$(tail -1 <<<"$out")"
    echo "grid ${grid} overload ${factor}x ($rate requests/s offered, load $load): $(head -1 <<<"$out")"
    echo "grid ${grid} overload ${factor}x: 200s median $(quantile 0.5 "$work/over" 200) ms, p99 $(quantile 0.99 "$work/over" 200) ms;" \
      "503s median $(quantile 0.5 "$work/over" 503) ms, p99 $(quantile 0.99 "$work/over" 503) ms"
    echo "grid ${grid} overload ${factor}x: /healthz admin: $(probe_summary "$work/probe_admin"); main: $(probe_summary "$work/probe_main")"
    echo "grid ${grid} overload ${factor}x: service CPU $(awk -v t="$ticks" -v hz="$hz" -v s="$seconds" \
      'BEGIN {printf "%.2f cores", t / hz / s}') while the load was offered"
    echo "grid ${grid} overload ${factor}x: RSS before $rss_before MB, peak $(cat "$work/peak") MB, ${settle} s after $rss_after MB"
    if ((factor == 5)); then
      summary+=("summary: grid ${grid} overload 5x: only 200 and 503: $only_ok (other $other, 503 without Retry-After $bad);\
 useful $ratio% of capacity (>= 80%: $( ((ratio >= 80)) && echo yes || echo no));\
 every /healthz within 1 s: admin $(probe_ok "$work/probe_admin"), main $(probe_ok "$work/probe_main")")
    fi
  done
  stop_server
done

# Slow clients (default --max-connections 512, --header-timeout 10 s).
node tests/http/helpers/make_request.js polygon spiral 64 >"$work/classify.json"
start_server --workers "$workers" --queue "$queue"
port="${url##*:}"
per=100
helpers=()
for g in $(seq $(((slow + per - 1) / per))); do
  n=$((slow - (g - 1) * per < per ? slow - (g - 1) * per : per))
  timeout $((slow_seconds + 5)) bash -c '
    trap "" PIPE
    port=$1 n=$2 secs=$3
    fds=()
    for i in $(seq "$n"); do exec {fd}<>"/dev/tcp/127.0.0.1/$port" && fds+=("$fd"); done
    line="GET /healthz HTTP/1.1 X-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
    until=$(($(date +%s) + secs)); k=0 reconnects=0
    while [[ $(date +%s) -lt $until ]]; do
      for idx in "${!fds[@]}"; do
        if ! printf "%s" "${line:$((k % ${#line})):1}" >&"${fds[$idx]}" 2>/dev/null; then
          old=${fds[$idx]}; exec {old}>&-
          exec {fd}<>"/dev/tcp/127.0.0.1/$port" 2>/dev/null && fds[$idx]=$fd && reconnects=$((reconnects + 1))
        fi
      done
      k=$((k + 1)); sleep 2
    done
    echo "$reconnects"' _ "$port" "$n" "$slow_seconds" >"$work/slow_group.$g" 2>/dev/null &
  helpers+=($!)
done
sleep 2
echo "slow clients: $(ss -tnH state established "( dport = :$port )" | wc -l) connections open to the main port after 2 s"
probe "$admin" "$((slow_seconds - 4))" "$work/slow_admin" &
helpers+=($!)
probe "$url" "$((slow_seconds - 4))" "$work/slow_main" &
helpers+=($!)
until=$(($(date +%s) + slow_seconds - 4))
for i in 1 2; do
  (while [[ $(date +%s) -lt $until ]]; do
     "${client_cpu[@]}" curl -s -o /dev/null --max-time 10 -w '%{http_code} %{time_total}\n' --json "@$work/classify.json" "$url/v1/polygons/classify" || true
     sleep 0.2
   done >"$work/slow_normal.$i") &
  helpers+=($!)
done
wait "${helpers[@]}"
cat "$work"/slow_normal.* >"$work/slow_normal"
echo "slow clients ($slow for ${slow_seconds} s, $(cat "$work"/slow_group.* | awk '{n += $1} END {print n + 0}') reconnects after a cut):" \
  "/healthz admin: $(probe_summary "$work/slow_admin"); main: $(probe_summary "$work/slow_main")"
normal="$(awk '{n++; t[n] = $2 * 1000; if ($1 == 200) ok++; else c[$1]++} END {
  printf "%d %d %.1f", ok, n, n ? 100 * ok / n : 0; for (k in c) printf " %s:%d", k, c[k]}' "$work/slow_normal")"
read -r normal_ok normal_n normal_pct normal_other <<<"$normal"
echo "slow clients: normal classify requests answered 200: $normal_ok/$normal_n = $normal_pct%" \
  "(median $(awk '{print $1, $2 * 1000}' "$work/slow_normal" | quantile 0.5 /dev/stdin 200) ms; others: ${normal_other:-none})"
echo "slow clients: connections refused $(curl -s "$admin/metrics" | awk '/^lipmap_rejected_total/ && /too_many_connections/ {n += $NF} END {print n + 0}')"
stop_server
summary+=("summary: slow clients: every health probe answered: admin $(probe_ok "$work/slow_admin"), main $(probe_ok "$work/slow_main");\
 normal requests answered $normal_pct% (>= 90%: $(awk -v p="$normal_pct" 'BEGIN {print (p >= 90 ? "yes" : "no")}'))")
printf '%s\n' "${summary[@]}"
