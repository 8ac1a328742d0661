#!/usr/bin/env bats
# `lipmap serve` against clients that hold connections: slow clients are cut at the request's deadline (408)
# while the admin listener keeps answering probes; connections beyond --max-connections get 503 at once; a
# pipelined request is answered; an answer the client did not take is logged as such; SIGTERM's exit status
# says whether the shutdown was clean. Raw requests go through bash's /dev/tcp, every one bounded by `timeout`.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() { require_tools; }

teardown() {
  check_recorded_answers
  local n
  for n in SLOW CAP PIPE TERM; do
    local pid_var="${n}_PID"
    if [ -n "${!pid_var:-}" ] && kill -0 "${!pid_var}" 2>/dev/null; then stop_server "$n" || true; fi
  done
}

# admin_port NAME: the admin listener's port from the "listening" line of server NAME's log.
admin_port() { grep -m1 '"event":"listening"' "$BATS_FILE_TMPDIR/$1.log" | jq -r .admin_port; }

# log_line NAME REQUEST_ID: the request log line of that request (waits up to 5 s for it).
log_line() {
  local i line=""
  for i in $(seq 50); do
    line="$(grep -a '"event":"request"' "$BATS_FILE_TMPDIR/$1.log" | grep -a "\"request_id\":\"$2\"" | head -n 1 || true)"
    [ -n "$line" ] && break
    sleep 0.1
  done
  echo "$line"
}

@test "slow clients: 80 connections sending a header byte a second for 10 s; probes on the admin port all answered within 1 s, the slow ones cut with 408" {
  start_server SLOW --workers 1 --queue 4 --max-connections 40 --admin-port 0 --header-timeout 3
  local port="${SLOW_URL##*:}" admin
  admin="$(admin_port SLOW)"
  [ "$admin" -gt 0 ]
  # One bash holds all 80 connections: the request line at once, then one header byte a second; a connection the server
  # closed just fails its writes (SIGPIPE ignored).
  timeout 15 bash -c '
    trap "" PIPE
    fds=()
    for i in $(seq 80); do exec {fd}<>/dev/tcp/127.0.0.1/$1 && fds+=("$fd"); done
    for fd in "${fds[@]}"; do printf "GET /healthz HTTP/1.1\r\n" >&"$fd" 2>/dev/null || true; done
    line="X-Slow-Header: aaaaaaaaaa"
    for k in $(seq 10); do
      for fd in "${fds[@]}"; do printf "%s" "${line:$((k - 1)):1}" >&"$fd" 2>/dev/null || true; done
      sleep 1
    done' _ "$port" &
  local slow=$! probes=0 ok=0
  sleep 1
  for i in $(seq 8); do
    probes=$((probes + 1))
    if curl -sS --max-time 1 -o /dev/null -w '%{http_code}' "http://127.0.0.1:$admin/healthz" | grep -qx 200; then ok=$((ok + 1)); fi
    call GET "http://127.0.0.1:$admin/readyz"
    expect 200
    sleep 1
  done
  wait "$slow" || true
  [ "$ok" = "$probes" ] || { echo "admin /healthz answered $ok of $probes probes within 1 s" >&2; return 1; }
  # The connections beyond the 40 were refused at once; those served were cut at the 3 s header deadline.
  grep -a '"event":"connection_refused"' "$BATS_FILE_TMPDIR/SLOW.log" | head -n 1 | grep -q too_many_connections
  [ "$(grep -a '"event":"request"' "$BATS_FILE_TMPDIR/SLOW.log" | grep -ac '"status":408')" -ge 1 ]
  # Once they are gone the main port answers again.
  call GET "$SLOW_URL/healthz"
  expect 200
  call GET "$SLOW_URL/metrics"
  expect 200
  grep -q '^lipmap_rejected_total{reason="too_many_connections"} [1-9]' "$answer"
}

@test "a request whose headers or body do not arrive within the deadline gets 408 and the connection closes" {
  start_server SLOW --workers 1 --header-timeout 1 --request-timeout 2
  local port="${SLOW_URL##*:}" out
  # Headers: the line comes, the rest never; answered 408 after ~1 s, then closed (nothing more read).
  out="$(timeout 6 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; printf "GET /healthz HTTP/1.1\r\nHost: x\r\n" >&3; cat <&3' _ "$port")"
  grep -q '^HTTP/1.1 408' <<<"$out"
  grep -q '"code":"request_timeout"' <<<"$out"
  [ "$(grep -c '^HTTP/1' <<<"$out")" = 1 ]
  # Body: announced 100 bytes, 10 sent: 408 at the 2 s whole-request deadline.
  out="$(timeout 6 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; printf "POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"polygon\"" >&3; cat <&3' _ "$port")"
  grep -q '^HTTP/1.1 408' <<<"$out"
  grep -q '"code":"request_timeout"' <<<"$out"
  call GET "$SLOW_URL/healthz"
  expect 200
}

@test "beyond --max-connections a connection gets 503 too_many_connections with Retry-After at once" {
  start_server CAP --workers 1 --max-connections 2
  local port="${CAP_URL##*:}"
  # Two idle connections fill the capacity (each is held until its keep-alive wait, 2 s, ends).
  exec {c1}<>"/dev/tcp/127.0.0.1/$port"
  exec {c2}<>"/dev/tcp/127.0.0.1/$port"
  sleep 0.3
  call GET "$CAP_URL/healthz"
  expect 503 too_many_connections
  [ "$(header Retry-After)" = 1 ]
  exec {c1}>&- {c2}>&-
  sleep 0.5
  call GET "$CAP_URL/healthz"
  expect 200
}

@test "a pipelined second request on one connection is answered" {
  start_server PIPE --workers 1
  local port="${PIPE_URL##*:}" out
  out="$(timeout 5 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; printf "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\nGET /version HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" >&3; cat <&3' _ "$port")"
  [ "$(grep -ao 'HTTP/1.1 200 OK' <<<"$out" | wc -l)" = 2 ]
  grep -q '"version"' <<<"$out"
  # Three at once, a POST with its body among them.
  out="$(timeout 5 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; b="{\"polygon\": [[0,0],[1,0],[0,1]]}"; printf "POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: ${#b}\r\n\r\n%sGET /healthz HTTP/1.1\r\nHost: x\r\n\r\nGET /readyz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" "$b" >&3; cat <&3' _ "$port")"
  [ "$(grep -ao 'HTTP/1.1 200 OK' <<<"$out" | wc -l)" = 3 ]  # a body without a final newline: not ^
  grep -q '"verdict":"simple"' <<<"$out"
}

@test "an answer the client did not take is logged 499 with the status it was sent with" {
  start_server PIPE --workers 1 --test-hooks
  local port="${PIPE_URL##*:}"
  # The client sends its request and closes at once; the answer comes 300 ms later.
  timeout 5 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; b="{\"polygon\": [[0,0],[1,0],[0,1]]}"; printf "POST /v1/polygons/classify HTTP/1.1\r\nHost: x\r\nX-Request-Id: gone-early\r\nX-Lipmap-Test-Delay-Ms: 300\r\nContent-Type: application/json\r\nContent-Length: ${#b}\r\n\r\n%s" "$b" >&3; exec 3>&-' _ "$port"
  line="$(log_line PIPE gone-early)"
  [ -n "$line" ]
  [ "$(jq -r .status <<<"$line")" = 499 ] || { echo "$line" >&2; return 1; }
  [ "$(jq -r .sent_status <<<"$line")" = 200 ]
  # A client that reads its answer is logged with it.
  call POST "$PIPE_URL/v1/polygons/classify" -H 'X-Request-Id: read-whole' --json '{"polygon": [[0,0],[1,0],[0,1]]}'
  expect 200
  [ "$(jq -r .status <<<"$(log_line PIPE read-whole)")" = 200 ]
}

@test "SIGTERM: exit 0 after a clean drain, non-zero when work ignored its cancellation" {
  start_server TERM --workers 1 --grace 0 --test-hooks
  stop_server TERM || true
  [ "$stop_status" = 0 ]
  start_server TERM --workers 1 --grace 0 --test-hooks
  curl -sS -o /dev/null --max-time 30 -X POST "$TERM_URL/v1/polygons/classify" -H 'X-Lipmap-Test-Delay-Ms: 14000' \
    -H 'X-Lipmap-Test-Fault: ignore_cancel' --json '{"polygon": [[0,0],[1,0],[0,1]]}' &
  local client=$!
  for i in $(seq 50); do
    curl -s "$TERM_URL/metrics" | grep -q '^lipmap_workers_busy 1' && break
    sleep 0.1
  done
  stop_server TERM || true
  wait "$client" || true
  [ "$stop_status" != 0 ] && [ "$stop_status" != timeout ] || { echo "exit status $stop_status" >&2; return 1; }
  grep -a '"event":"stopped"' "$BATS_FILE_TMPDIR/TERM.log" | tail -n 1 | grep -q '"clean":false'
}
