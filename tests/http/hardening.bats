#!/usr/bin/env bats
# `lipmap serve` against requests framed to cost it time or to be read two ways: work it cannot take now is
# refused before its body is read; Content-Length and Transfer-Encoding it would misread are refused at once;
# Range is ignored; answers go out uncompressed whatever the client accepts. Raw requests go through bash's
# /dev/tcp, every one bounded with `timeout`.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() { serve_for_file MAIN --workers 2 --queue 16; }

teardown_file() { stop_server MAIN; }

teardown() {
  check_recorded_answers
  if [ -n "${FULL_PID:-}" ] && kill -0 "$FULL_PID" 2>/dev/null; then stop_server FULL || true; fi
}

# raw PORT PAYLOAD [SECONDS]: writes PAYLOAD, in a single write, on a new connection and reads until the
# server closes it or SECONDS (default 3) pass. Sets $raw_file (all bytes read), $raw_status (status of the
# first answer), $raw_ctype, $raw_body (the first answer's body, by its Content-Length), $raw_answers (how many
# status lines came back), $raw_closed (1 when the server closed the connection in time) and $raw_ms.
raw_no=0
raw() {
  raw_no=$((raw_no + 1))
  raw_file="$BATS_TEST_TMPDIR/raw.$raw_no"
  local t0 t1
  t0=$(date +%s%N)
  raw_closed=1
  # One write() for the whole payload: bash line-buffers its printf, so printing to the socket would send
  # every header line apart, and a body meant to arrive with its head might not have arrived yet.
  printf '%s' "$2" >"$raw_file.out"
  timeout "${3:-3}" bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; cat "$2" >&3; cat <&3' _ "$1" "$raw_file.out" >"$raw_file" ||
    raw_closed=0
  t1=$(date +%s%N)
  raw_ms=$(((t1 - t0) / 1000000))
  raw_status="$(head -n 1 "$raw_file" | awk '{print $2}')"
  raw_answers="$(grep -ac '^HTTP/1\.[01] [0-9][0-9][0-9]' "$raw_file" || true)"
  local head
  head="$(sed -n '1,/^\r$/p' "$raw_file" | tr -d '\r')"
  raw_ctype="$(grep -i '^content-type:' <<<"$head" | head -n 1 | sed -E 's/^[^:]*:[[:space:]]*//')"
  local len
  len="$(grep -i '^content-length:' <<<"$head" | head -n 1 | sed -E 's/^[^:]*:[[:space:]]*//')"
  raw_body="$(awk 'BEGIN{RS="\r\n\r\n"} NR==1{next} {printf "%s%s", sep, $0; sep="\r\n\r\n"}' "$raw_file" | head -c "${len:-0}")"
  raw_headers="$head"
}

# raw_problem STATUS... : the first raw answer has one of these statuses and is a problem+json whose status
# field says the same.
raw_problem() {
  local s ok=0
  for s in "$@"; do [ "$raw_status" = "$s" ] && ok=1; done
  [ "$ok" = 1 ] || { echo "HTTP $raw_status, wanted one of $*: $(head -c 600 "$raw_file")" >&2; return 1; }
  [[ "$raw_ctype" == application/problem+json* ]] || { echo "not a problem answer: $raw_ctype" >&2; return 1; }
  [ "$(jq -r .status <<<"$raw_body")" = "$raw_status" ] || { echo "problem status != HTTP status: $raw_body" >&2; return 1; }
}

POLYGON='{"polygon": [[0,0],[1,0],[1,1]]}'

@test "full queue: POST /v1/parametrize and /v1/jobs are refused 503 before their body is read" {
  start_server FULL --workers 1 --queue 1 --test-hooks
  port="${FULL_URL##*:}"
  req="$(make_body grid4_square grid 4 square)"
  call -s job.schema.json POST "$FULL_URL/v1/jobs" -H 'X-Lipmap-Test-Delay-Ms: 8000' --json "@$req"
  expect 202
  wait_for_job "$FULL_URL" "$(jq -r .id "$answer")" running
  call -s job.schema.json POST "$FULL_URL/v1/jobs" -H 'X-Lipmap-Test-Delay-Ms: 8000' --json "@$req"
  expect 202
  # A body announced at 50 MB of which only 10 bytes ever come: the refusal cannot have waited for it.
  for path in /v1/parametrize /v1/jobs; do
    raw "$port" "POST $path HTTP/1.1"$'\r\nHost: x\r\nContent-Type: application/json\r\nX-Request-Id: early-'"${path//\//_}"$'\r\nContent-Length: 50000000\r\n\r\n{"mesh": {' 3
    raw_problem 503
    [ "$(jq -r .code <<<"$raw_body")" = queue_full ]
    grep -qiE '^Retry-After: [1-9][0-9]*$' <<<"$raw_headers"
    [ "$raw_closed" = 1 ]     # the unread body is never taken for a next request: the connection ends
    [ "$raw_answers" = 1 ]
    [ "$raw_ms" -lt 2000 ]
  done
  # A small body sent whole with its head is dropped unread and the connection stays open: a request pipelined
  # after it is answered on it (a retry need not pay for a new connection).
  raw "$port" "POST /v1/polygons/classify HTTP/1.1"$'\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: '"${#POLYGON}"$'\r\n\r\n'"$POLYGON"$'GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n' 3
  raw_problem 503
  [ "$(jq -r .code <<<"$raw_body")" = queue_full ]
  # (the second status line follows the first answer's body, which ends without a newline)
  [ "$(grep -ao 'HTTP/1\.1 [0-9][0-9][0-9]' "$raw_file" | wc -l)" = 2 ] || { echo "$(cat "$raw_file")" >&2; return 1; }
  grep -aq 'HTTP/1\.1 200' "$raw_file"
  # A whole 8 MB body sent by curl gets the same answer, and the connection closing does not lose it.
  big="$BATS_TEST_TMPDIR/big.json"
  { printf '{"pad": "'; head -c 8000000 /dev/zero | tr '\0' a; printf '"}'; } >"$big"
  for path in /v1/parametrize /v1/jobs; do
    call POST "$FULL_URL$path" -H "X-Request-Id: big-${path//\//_}" --json "@$big"
    expect 503 queue_full
    [[ "$(header Retry-After)" =~ ^[1-9][0-9]*$ ]]
  done
  # The body was never parsed: the log lines of these refusals have no parse_ms.
  for id in early-_v1_parametrize early-_v1_jobs big-_v1_parametrize big-_v1_jobs; do
    line=""
    for i in $(seq 20); do
      line="$(grep -a '"event":"request"' "$BATS_FILE_TMPDIR/FULL.log" | grep -a "\"request_id\":\"$id\"" | head -n 1 || true)"
      [ -n "$line" ] && break
      sleep 0.1
    done
    [ -n "$line" ] || { echo "no log line for $id" >&2; return 1; }
    [ "$(jq -r .status <<<"$line")" = 503 ]
    [ "$(jq -r 'has("parse_ms")' <<<"$line")" = false ] || { echo "parsed before refusing: $line" >&2; return 1; }
  done
  # Work the service can take is still read and answered on the same connection as before.
  call GET "$FULL_URL/healthz"
  expect 200
  stop_server FULL
  [ "$stop_status" = 0 ]
}

@test "Content-Length headers that disagree are refused 400; identical ones are one length" {
  port="${MAIN_URL##*:}"
  raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 32\r\nContent-Length: 5\r\n\r\n'"$POLYGON"
  raw_problem 400
  [ "$(jq -r .code <<<"$raw_body")" = bad_request ]
  [ "$raw_answers" = 1 ]
  raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 5\r\nContent-Length: 32\r\n\r\n'"$POLYGON"
  raw_problem 400
  raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 32\r\nContent-Length: 32\r\nConnection: close\r\n\r\n'"$POLYGON"
  [ "$raw_status" = 200 ]
  [ "$(jq -r .verdict <<<"$raw_body")" = simple ]
}

@test "a transfer coding other than chunked is refused (400/501 problem), never read as if absent" {
  port="${MAIN_URL##*:}"
  for te in gzip identity 'x-custom' 'chunked, gzip'; do
    raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: '"$te"$'\r\nContent-Length: 32\r\n\r\n'"$POLYGON"
    if [ "$te" = 'chunked, gzip' ]; then raw_problem 400 411 501; else raw_problem 400 501; fi
    [ "$raw_answers" = 1 ]
    [ "$raw_closed" = 1 ]
  done
  # a chunked body that is refused unread is not taken for the requests it may contain
  raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\nGET /healthz HTTP/1.1\r\nHost: x\r\n\r\n'
  raw_problem 411
  [ "$raw_answers" = 1 ]
  [ "$raw_closed" = 1 ]
}

@test "an invalid Content-Length is answered at once with a 400/413 problem" {
  port="${MAIN_URL##*:}"
  for cl in -1 18446744073709551616 99999999999999999999 abc '1 2' '+5' 0x10 ' 7x'; do
    raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: '"$cl"$'\r\n\r\n{}' 5
    raw_problem 400 413
    [ "$raw_ms" -lt 2000 ] || { echo "Content-Length '$cl' answered after $raw_ms ms" >&2; return 1; }
    [ "$raw_answers" = 1 ]
  done
  # a valid length above the limit: 413 at once, without waiting for the body
  raw "$port" $'POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 9000000000\r\n\r\n{}' 5
  raw_problem 413
  [ "$(jq -r .code <<<"$raw_body")" = payload_too_large ]
  [ "$raw_ms" -lt 2000 ]
  call GET "$MAIN_URL/healthz"
  expect 200
}

@test "Range is ignored: a static document answers 200 with the whole body; no range makes a non-problem 416" {
  port="${MAIN_URL##*:}"
  call GET "$MAIN_URL/v1/openapi.json"
  expect 200
  whole="$answer"
  jq -e .openapi "$whole" >/dev/null
  for range in 'bytes=0-10' 'bytes=5-' 'bytes=-20' 'bytes=0-1,3-4' 'bytes=0-10,5-1' 'bytes=99999999-' 'bytes=10-5' \
               'items=0-3' 'bytes=abc'; do
    call GET "$MAIN_URL/v1/openapi.json" -H "Range: $range"
    if [ "$code" = 200 ]; then
      [ -z "$(header Content-Range)" ] || { echo "Range $range: Content-Range $(header Content-Range)" >&2; return 1; }
      cmp -s "$answer" "$whole" || { echo "Range $range: not the whole document" >&2; return 1; }
    else
      # a range the HTTP layer cannot parse may be refused, but only as a whole problem+json
      expect 416
      [[ "$ctype" == application/problem+json* ]]
      [ -z "$(header Content-Range)" ]
      jq -e .code "$answer" >/dev/null
    fi
  done
  # the same on a problem answer: never cut to the range
  call GET "$MAIN_URL/v1/nothing-here" -H 'Range: bytes=0-10'
  expect 404 not_found
  [ -z "$(header Content-Range)" ]
  # and on a raw connection, a multi-range is never a multipart answer
  raw "$port" $'GET /v1/openapi.json HTTP/1.1\r\nHost: x\r\nRange: bytes=0-1,3-4\r\nConnection: close\r\n\r\n'
  [ "$raw_status" = 200 ]
  [[ "$raw_ctype" == application/json* ]]
}

@test "answers go out uncompressed whatever the client accepts (gzip, br): compression is the proxy's" {
  request="$(make_body grid12 grid 12 spiral)"
  for enc in 'gzip' 'br' 'gzip, deflate, br' 'BR;q=1.0, *'; do
    call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' -H "accept-encoding: $enc" \
      --data-binary "@$request"
    expect 200
    [ -z "$(header Content-Encoding)" ] || { echo "Accept-Encoding $enc: Content-Encoding $(header Content-Encoding)" >&2; return 1; }
    check_map "$request"
  done
  call GET "$MAIN_URL/v1/openapi.json" -H 'Accept-Encoding: gzip, br'
  expect 200
  [ -z "$(header Content-Encoding)" ]
  jq -e .openapi "$answer" >/dev/null
}
