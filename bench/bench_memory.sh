#!/usr/bin/env bash
# Peak memory of requests against the constants of server/http/memory_budget.cpp (docs/api.md "Memory").
#
#   bash bench/bench_memory.sh          (loads the machine for a minute or two: run it alone, under the build lock)
#
# One `lipmap serve --workers 1` with a memory budget that refuses nothing; for each request the peak RSS is
# reset (/proc/PID/clear_refs 5), VmRSS read, the request sent, and VmHWM read after: the growth is what the
# request cost the process at its peak. Rows:
#   parse, SAX      a parametrize body of N vertices and faces (numbers as exporters write them, 17 digits, or
#                   short ones: "[1,2,3]"), refused by --max-vertices right after parsing: parse cost per body byte
#   parse, DOM      the same with a string as the last coordinate: the SAX reader gives up and the whole body is
#                   parsed into a DOM to name the error (400 wrong_type); and a body of empty objects, the most
#                   a DOM costs per body byte
#   classify parse  a classify body of N points (a DOM), refused by --max-polygon-vertices after parsing
#   table           classify of the double loop of N vertices (nothing for App. C's reduction): bytes per n^2
#   parametrize     the N x N grid on the spiral (2 (N-1)^2 triangles), target density 1: bytes per triangle
# Environment: LIPMAP_BUILD_DIR (build), BENCH_BODY_MB ("8 32": the parse rows' body sizes), BENCH_GRIDS ("72 160 250"),
# BENCH_LOOPS ("1000 2000 4000").
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
lipmap="${LIPMAP_BUILD_DIR:-build}/server/lipmap"
sizes="${BENCH_BODY_MB:-8 32}"
grids="${BENCH_GRIDS:-72 160 250}"
loops="${BENCH_LOOPS:-1000 2000 4000}"
[[ -x "$lipmap" ]] || { echo "bench_memory: build $lipmap first" >&2; exit 1; }
for t in curl jq node; do command -v "$t" >/dev/null || { echo "bench_memory: $t is needed" >&2; exit 1; }; done

work="$(mktemp -d)"
server=""
cleanup() {
  if [[ -n "$server" ]] && kill -0 "$server" 2>/dev/null; then kill -TERM "$server"; wait "$server" 2>/dev/null; fi
  rm -rf "$work"
}
trap cleanup EXIT

"$lipmap" serve --host 127.0.0.1 --port 0 --workers 1 --log-level warn --max-vertices 3 --max-polygon-vertices 4000 \
  --memory-budget $((1 << 50)) --max-body-bytes $((1 << 30)) --deadline 600 2>"$work/serve.log" &
server=$!
for i in $(seq 100); do
  line="$(grep -m1 '"event":"listening"' "$work/serve.log" 2>/dev/null || true)"
  [[ -n "$line" ]] && break
  sleep 0.1
done
[[ -n "$line" ]] || { echo "bench_memory: the service did not start" >&2; cat "$work/serve.log" >&2; exit 1; }
url="http://127.0.0.1:$(jq -r .port <<<"$line")"
[[ -w "/proc/$server/clear_refs" ]] || { echo "bench_memory: cannot reset the peak RSS (/proc/$server/clear_refs)" >&2; exit 1; }
kb() { awk -v k="$1" '$1 == k":" {print $2}' "/proc/$server/status"; }

# measure PATH FILE [curl options]: prints "STATUS GROWTH_BYTES"
measure() {
  local path="$1" file="$2" before peak code
  shift 2
  echo 5 >"/proc/$server/clear_refs"
  before="$(kb VmRSS)"
  code="$(curl -s -o /dev/null -w '%{http_code}' --max-time 600 -H 'Content-Type: application/json' \
    --data-binary "@$file" "$@" "$url$path")"
  peak="$(kb VmHWM)"
  echo "$code $(((peak - before) * 1024))"
}
# mb BYTES, ratio A B: the figures of a row (awk: no bc on a minimal machine)
mb() { awk -v b="$1" 'BEGIN {printf "%.1f", b / 1048576}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2f", a / b}'; }
row() { printf '%-16s %-34s %10s %6s %10s MB %12s\n' "$@"; }

# body VERTICES STYLE LAST: a parametrize body with VERTICES vertices and as many faces; LAST ends the vertices
body() {
  awk -v n="$1" -v style="$2" -v last="$3" 'BEGIN {
    printf "{\"mesh\": {\"vertices\": ["
    for (i = 0; i < n; i++) {
      if (style == "short") printf "[%d,%d,%d],", i % 10, (i + 3) % 10, (i + 7) % 10
      else printf "[%.17g,%.17g,%.17g],", i / 3.0 + 0.1, i / 7.0 + 0.2, i / 11.0 + 0.3
    }
    printf "%s], \"faces\": [", last
    for (i = 0; i < n; i++) printf "[%d,%d,%d],", i, (i + 1) % n, (i + 2) % n
    printf "[0,1,2]]}, \"boundary\": {\"positions\": [[0,0],[1,0],[0,1]]}}"
  }'
}

echo "bench_memory: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); peak RSS growth per request (VmHWM after - VmRSS before)"
printf '%-16s %-34s %10s %6s %13s %12s\n' row request "body" status growth "per unit"
for mb in $sizes; do
  for style in digits short; do
    per=$([[ $style == short ]] && echo 40 || echo 96)  # body bytes per vertex + face
    n=$((mb * 1000000 / per))
    body "$n" "$style" "[0,0,0]" >"$work/sax.json"
    body "$n" "$style" "[0,0,\"x\"]" >"$work/dom.json"
    bytes=$(stat -c %s "$work/sax.json")
    read -r code grow <<<"$(measure /v1/parametrize "$work/sax.json")"
    row "parse, SAX" "$n vertices+faces ($style)" "$((bytes / 1000000)) MB" "$code" "$(mb "$grow")" "$(ratio "$grow" "$bytes") B/B"
    read -r code grow <<<"$(measure /v1/parametrize "$work/dom.json")"
    row "parse, DOM" "$n vertices+faces ($style)" "$((bytes / 1000000)) MB" "$code" "$(mb "$grow")" "$(ratio "$grow" "$bytes") B/B"
  done
  # the worst a DOM can do per byte: empty objects ("{}," = 3 bytes, each a map of its own in the DOM)
  n=$((mb * 1000000 / 3))
  awk -v n="$n" 'BEGIN {printf "{\"mesh\": {\"vertices\": ["; for (i = 0; i < n; i++) printf "{},"; printf "{}]}}"}' >"$work/dom.json"
  bytes=$(stat -c %s "$work/dom.json")
  read -r code grow <<<"$(measure /v1/parametrize "$work/dom.json")"
  row "parse, DOM" "$n empty objects" "$((bytes / 1000000)) MB" "$code" "$(mb "$grow")" "$(ratio "$grow" "$bytes") B/B"
  n=$((mb * 1000000 / 30))
  awk -v n="$n" 'BEGIN {printf "{\"polygon\": ["; for (i = 0; i < n; i++) printf "[%.12g,%.12g],", i / 3.0, i / 7.0; printf "[0,0]]}"}' >"$work/poly.json"
  bytes=$(stat -c %s "$work/poly.json")
  read -r code grow <<<"$(measure /v1/polygons/classify "$work/poly.json")"
  row "classify parse" "$n points" "$((bytes / 1000000)) MB" "$code" "$(mb "$grow")" "$(ratio "$grow" "$bytes") B/B"
done
rm -f "$work"/*.json
for n in $loops; do
  node tests/http/helpers/make_request.js polygon loop2 "$n" >"$work/loop.json"
  read -r code grow <<<"$(measure /v1/polygons/classify "$work/loop.json")"
  row "table" "double loop, $n vertices" "$(($(stat -c %s "$work/loop.json") / 1000)) kB" "$code" "$(mb "$grow")" "$(ratio "$grow" $((n * n))) B/n^2"
done
stop() { kill -TERM "$server"; wait "$server" 2>/dev/null; server=""; }
stop
"$lipmap" serve --host 127.0.0.1 --port 0 --workers 1 --log-level warn --memory-budget $((1 << 50)) \
  --max-body-bytes $((1 << 30)) --deadline 600 2>"$work/serve.log" &
server=$!
for i in $(seq 100); do
  line="$(grep -m1 '"event":"listening"' "$work/serve.log" 2>/dev/null || true)"
  [[ -n "$line" ]] && break
  sleep 0.1
done
url="http://127.0.0.1:$(jq -r .port <<<"$line")"
for g in $grids; do
  node tests/http/helpers/make_request.js grid "$g" spiral >"$work/grid.json"
  t=$((2 * (g - 1) * (g - 1)))
  read -r code grow <<<"$(measure /v1/parametrize "$work/grid.json")"
  row "parametrize" "grid $g: $t triangles, $((g * g)) vertices" "$(($(stat -c %s "$work/grid.json") / 1000)) kB" "$code" \
    "$(mb "$grow")" "$(ratio "$grow" "$t") B/tri"
done
