#!/usr/bin/env bats
# `lipmap serve` under load and at its limits: a full queue (503 + Retry-After), deadlines (504 / job failed),
# 50+ concurrent requests of mixed sizes, cancelling a running job, result retention (410 Gone), and SIGTERM
# while a request runs. Slow work comes from the engine itself where that is deterministic enough, and
# otherwise from the test hook X-Lipmap-Test-Delay-Ms (servers started with --test-hooks), which holds a
# worker for that long while checking the job's cancel token every 2 ms, exactly as the engine's loops do.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() {
  require_tools
}

teardown() {
  check_recorded_answers
  # servers a test started and did not stop (a failed assertion): stop them
  for name in QUEUE DEADLINE LOAD CANCEL WAIT TTL COUNT TERM GRACE ENVS TUNE OWN; do
    pid_var="${name}_PID"
    if [ -n "${!pid_var:-}" ] && kill -0 "${!pid_var}" 2>/dev/null; then stop_server "$name" || true; fi
  done
}

# slow_job URL MS: submits a job that holds a worker for MS milliseconds; sets $job_id.
slow_job() {
  call -s job.schema.json POST "$1/v1/jobs" -H "X-Lipmap-Test-Delay-Ms: $2" --json "@$(make_body grid4_square grid 4 square)"
  job_id="$(jq -r '.id // empty' "$answer")"
}

@test "queue full (1 worker, queue 1): the third concurrent job is refused 503 queue_full with Retry-After" {
  start_server QUEUE --workers 1 --queue 1 --test-hooks
  slow_job "$QUEUE_URL" 3000
  expect 202
  first="$job_id"
  wait_for_job "$QUEUE_URL" "$first" running
  slow_job "$QUEUE_URL" 3000
  expect 202
  second="$job_id"
  [ "$(jq -r .state "$answer")" = queued ]
  slow_job "$QUEUE_URL" 10
  expect 503 queue_full
  [[ "$(header Retry-After)" =~ ^[1-9][0-9]*$ ]]
  [ "$(jq -r .retry_after_seconds "$answer")" = "$(header Retry-After)" ]
  # synchronous calls meet the same queue
  call POST "$QUEUE_URL/v1/polygons/classify" --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 503 queue_full
  call GET "$QUEUE_URL/metrics"
  grep -qE '^lipmap_queue_depth 1$' "$answer"
  grep -qE '^lipmap_workers_busy 1$' "$answer"
  grep -qE '^lipmap_rejected_total\{reason="queue_full"\} 2$' "$answer"
  grep -qE '^lipmap_jobs\{state="queued"\} 1$' "$answer"
  # the probes still answer at once
  call GET "$QUEUE_URL/healthz"
  expect 200
  # cancelling the queued job frees its place
  call -s job.schema.json DELETE "$QUEUE_URL/v1/jobs/$second"
  expect 200
  [ "$(jq -r .state "$answer")" = cancelled ]
  slow_job "$QUEUE_URL" 10
  expect 202
  wait_for_job "$QUEUE_URL" "$job_id" succeeded
  stop_server QUEUE
  [ "$stop_status" = 0 ]
}

@test "deadline exceeded: a synchronous call is 504 deadline_exceeded, a job is failed with the reason" {
  start_server DEADLINE --workers 1 --deadline 0.2 --test-hooks
  call POST "$DEADLINE_URL/v1/parametrize" -H 'X-Lipmap-Test-Delay-Ms: 5000' --json "@$(make_body grid4_square grid 4 square)"
  expect 504 deadline_exceeded
  call POST "$DEADLINE_URL/v1/polygons/classify" -H 'X-Lipmap-Test-Delay-Ms: 5000' --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 504 deadline_exceeded
  slow_job "$DEADLINE_URL" 5000
  expect 202
  wait_for_job "$DEADLINE_URL" "$job_id" failed
  [ "$(jq -r .error.code "$answer")" = deadline_exceeded ]
  [ "$(jq -r .error.status "$answer")" = 504 ]
  [[ "$(jq -r .error.detail "$answer")" == *"deadline of 0.2 s"* ]]
  # and real engine work: a 115k-triangle spiral (about 1 s on this machine) does not fit in 0.2 s
  call POST "$DEADLINE_URL/v1/parametrize" --json "@$(make_body grid240_spiral grid 240 spiral)"
  expect 504 deadline_exceeded
  # the worker is free again: quick work still fits
  call POST "$DEADLINE_URL/v1/polygons/classify" --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 200
  stop_server DEADLINE
}

@test "60 concurrent requests of mixed sizes and kinds (2 workers): every one answered correctly" {
  start_server LOAD --workers 2 --queue 64
  dir="$BATS_TEST_TMPDIR/load"
  mkdir -p "$dir"
  # the mix: (endpoint, request, expected status) per line
  : >"$dir/plan"
  for i in $(seq 0 59); do
    case $((i % 6)) in
      0) n=$((4 + i % 13)); echo "parametrize $(make_body "grid${n}_spiral" grid "$n" spiral) 200" ;;
      1) n=$((5 + i % 17)); echo "parametrize $(make_body "grid${n}_circle" grid "$n" circle) 200" ;;
      2) n=$((8 + i % 20)); echo "classify $(make_body "poly_spiral$n" polygon spiral "$n") 200" ;;
      3) echo "parametrize $(make_body grid6_clockwise grid 6 clockwise) 422" ;;
      4) n=$((3 + i % 25)); echo "parametrize $(make_body "grid${n}_square" grid "$n" square) 200" ;;
      5) echo "parametrize $(make_body invalid_nonmanifold invalid nonmanifold) 422" ;;
    esac >>"$dir/plan"
  done
  [ "$(wc -l <"$dir/plan")" -eq 60 ]
  # all at once: 60 curl processes against 127.0.0.1
  # each line: index kind file expected -> $1 $2 $3 $4 of the inner script
  nl -v0 -w1 -s' ' "$dir/plan" | DIR="$dir" URL="$LOAD_URL" xargs -P 60 -L 1 bash -c '
    path=/v1/$2; [ "$2" = classify ] && path=/v1/polygons/classify
    curl -sS -o "$DIR/answer.$1" -w "%{http_code}" --max-time 120 --json "@$3" "$URL$path" >"$DIR/code.$1"
  ' _ || true
  i=0
  while read -r kind req want; do
    got="$(cat "$dir/code.$i" 2>/dev/null || echo none)"
    [ "$got" = "$want" ] || { echo "request $i ($kind $(basename "$req")): HTTP $got, wanted $want: $(head -c 300 "$dir/answer.$i")" >&2; return 1; }
    if [ "$want" = 200 ] && [ "$kind" = parametrize ]; then
      echo "schema parametrize-answer.schema.json $dir/answer.$i" >>"$BATS_TEST_TMPDIR/manifest"
      echo "map $req $dir/answer.$i" >>"$BATS_TEST_TMPDIR/manifest"
    elif [ "$want" = 200 ]; then
      echo "schema classify-answer.schema.json $dir/answer.$i" >>"$BATS_TEST_TMPDIR/manifest"
    else
      echo "schema problem.schema.json $dir/answer.$i" >>"$BATS_TEST_TMPDIR/manifest"
    fi
    i=$((i + 1))
  done <"$dir/plan"
  [ "$i" -eq 60 ]
  call GET "$LOAD_URL/metrics"
  grep -qE '^lipmap_http_requests_total\{route="/v1/parametrize",method="POST",status="200"\} 30$' "$answer"
  grep -qE '^lipmap_http_requests_total\{route="/v1/parametrize",method="POST",status="422"\} 20$' "$answer"
  grep -qE '^lipmap_http_requests_total\{route="/v1/polygons/classify",method="POST",status="200"\} 10$' "$answer"
  grep -qE '^lipmap_maps_total 30$' "$answer"
  stop_server LOAD
  [ "$stop_status" = 0 ]
}

@test "a job cancelled while running: DELETE -> 202, then state cancelled, result 409 job_cancelled" {
  start_server CANCEL --workers 1 --test-hooks
  slow_job "$CANCEL_URL" 20000
  wait_for_job "$CANCEL_URL" "$job_id" running
  call -s job.schema.json DELETE "$CANCEL_URL/v1/jobs/$job_id"
  expect 202
  [ "$(jq -r .cancel_requested "$answer")" = true ]
  wait_for_job "$CANCEL_URL" "$job_id" cancelled
  [ "$(jq -r .error.code "$answer")" = cancelled ]
  call GET "$CANCEL_URL/v1/jobs/$job_id/result"
  expect 409 job_cancelled
  stop_server CANCEL
}

@test "a real engine job cancelled while running stops early (the engine checks its token)" {
  start_server CANCEL --workers 1
  req="$(make_body grid240_spiral grid 240 spiral)"
  call -s job.schema.json POST "$CANCEL_URL/v1/jobs" --json "@$req"
  expect 202
  job_id="$(jq -r .id "$answer")"
  wait_for_job "$CANCEL_URL" "$job_id" running succeeded
  [ "$(jq -r .state "$answer")" = running ] || skip "the machine finished a 115k-triangle job before it could be cancelled"
  call DELETE "$CANCEL_URL/v1/jobs/$job_id"
  # 204: the job had already finished, and DELETE dropped it (tested in service.bats)
  [ "$code" != 204 ] || skip "the job finished before the cancellation reached it"
  expect 202
  start=$(date +%s%N)
  wait_for_job "$CANCEL_URL" "$job_id" cancelled succeeded
  [ "$(jq -r .state "$answer")" = cancelled ] || skip "the job finished before the cancellation reached it"
  elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
  [ "$elapsed_ms" -lt 5000 ] || { echo "cancellation took $elapsed_ms ms" >&2; return 1; }
  stop_server CANCEL
}

@test "long poll: GET /v1/jobs/{id}?wait=S answers when the job ends, or after S as it is; SIGTERM ends the wait" {
  start_server WAIT --workers 1 --test-hooks
  # One poll waiting up to 30 s gets the finished job (a poll without wait this early sees it queued or running).
  slow_job "$WAIT_URL" 800
  call -s job.schema.json GET "$WAIT_URL/v1/jobs/$job_id?wait=30"
  expect 200
  [ "$(jq -r .state "$answer")" = succeeded ]
  # A short wait on a long job answers with the job as it is.
  slow_job "$WAIT_URL" 20000
  long="$job_id"
  call -s job.schema.json GET "$WAIT_URL/v1/jobs/$long?wait=0.2"
  expect 200
  [[ "$(jq -r .state "$answer")" =~ ^(queued|running)$ ]]
  # A job ended by a DELETE from another connection wakes its waiting poll.
  waited="$BATS_TEST_TMPDIR/waited"
  curl -sS -o "$waited" --max-time 60 "$WAIT_URL/v1/jobs/$long?wait=30" &
  poll=$!
  sleep 0.3
  call DELETE "$WAIT_URL/v1/jobs/$long"
  expect 202
  wait "$poll"
  [ "$(jq -r .state "$waited")" = cancelled ]
  echo "schema job.schema.json $waited" >>"$BATS_TEST_TMPDIR/manifest"
  # Not a number of seconds from 0 to 30: 400, naming the parameter.
  for bad in abc -1 30.5 nan inf 1e999 '' 0x10 '2%20s'; do
    call GET "$WAIT_URL/v1/jobs/$long?wait=$bad"
    expect 400 invalid_query_parameter
    [ "$(jq -r .parameter "$answer")" = wait ]
  done
  # SIGTERM: a poll still waiting answers at once with the job as it is, and the service exits 0.
  slow_job "$WAIT_URL" 20000
  curl -sS -o "$waited" -w '%{http_code}' --max-time 60 "$WAIT_URL/v1/jobs/$job_id?wait=30" >"$waited.code" &
  poll=$!
  sleep 0.3
  start=$(date +%s%N)
  kill -TERM "$WAIT_PID"
  wait "$poll"
  [ "$(cat "$waited.code")" = 200 ]
  [ "$(jq -r .id "$waited")" = "$job_id" ]
  stop_server WAIT
  [ "$stop_status" = 0 ]
  elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
  [ "$elapsed_ms" -lt 10000 ] || { echo "the waiting poll held the shutdown for $elapsed_ms ms" >&2; return 1; }
}

@test "results are dropped after their time (410 job_gone, reason expired)" {
  start_server TTL --workers 1 --result-ttl 1
  call -s job.schema.json POST "$TTL_URL/v1/jobs" --json "@$(make_body grid4_square grid 4 square)"
  job_id="$(jq -r .id "$answer")"
  wait_for_job "$TTL_URL" "$job_id" succeeded
  call GET "$TTL_URL/v1/jobs/$job_id/result"
  expect 200
  sleep 1.5
  call GET "$TTL_URL/v1/jobs/$job_id/result"
  expect 410 job_gone
  [ "$(jq -r .reason "$answer")" = expired ]
  call GET "$TTL_URL/metrics"
  grep -qE '^lipmap_job_results_dropped_total\{reason="expired"\} 1$' "$answer"
  stop_server TTL
}

@test "results beyond the count are dropped, oldest first (410 job_gone, reason evicted)" {
  start_server COUNT --workers 1 --max-results 2
  ids=()
  for i in 1 2 3; do
    call -s job.schema.json POST "$COUNT_URL/v1/jobs" --json "@$(make_body grid4_square grid 4 square)"
    ids+=("$(jq -r .id "$answer")")
    wait_for_job "$COUNT_URL" "${ids[-1]}" succeeded
  done
  call GET "$COUNT_URL/v1/jobs/${ids[0]}"
  expect 410 job_gone
  [ "$(jq -r .reason "$answer")" = evicted ]
  call GET "$COUNT_URL/v1/jobs/${ids[1]}/result"
  expect 200
  call GET "$COUNT_URL/v1/jobs/${ids[2]}/result"
  expect 200
  stop_server COUNT
}

@test "SIGTERM during a request: the request completes (200, valid), new connections are refused, exit 0" {
  start_server TERM --workers 1 --grace 20 --test-hooks
  req="$(make_body grid10_spiral grid 10 spiral)"
  out="$BATS_TEST_TMPDIR/inflight"
  curl -sS -o "$out.body" -w '%{http_code}' --max-time 60 -H 'X-Lipmap-Test-Delay-Ms: 1500' --json "@$req" \
    "$TERM_URL/v1/parametrize" >"$out.code" &
  curl_pid=$!
  # wait until the worker has it, then signal
  for i in $(seq 100); do
    curl -s "$TERM_URL/metrics" | grep -qE '^lipmap_workers_busy 1$' && break
    sleep 0.05
  done
  kill -TERM "$TERM_PID"
  sleep 0.3
  # the listener is closed: a new connection is refused while the in-flight request finishes
  run curl -sS --max-time 5 "$TERM_URL/healthz"
  [ "$status" -ne 0 ]
  wait "$curl_pid"
  [ "$(cat "$out.code")" = 200 ]
  echo "schema parametrize-answer.schema.json $out.body" >>"$BATS_TEST_TMPDIR/manifest"
  echo "map $req $out.body" >>"$BATS_TEST_TMPDIR/manifest"
  stop_server TERM
  [ "$stop_status" = 0 ]
  grep -q '"event":"signal","signal":"SIGTERM"' "$BATS_FILE_TMPDIR/TERM.log"
  grep -q '"event":"stopped".*"clean":true' "$BATS_FILE_TMPDIR/TERM.log"
}

@test "SIGTERM with work longer than the grace period: it is cancelled (503 shutting_down), exit 0 soon after" {
  start_server GRACE --workers 1 --grace 0.5 --test-hooks
  out="$BATS_TEST_TMPDIR/inflight"
  curl -sS -o "$out.body" -w '%{http_code}' --max-time 60 -H 'X-Lipmap-Test-Delay-Ms: 30000' \
    --json '{"polygon": [[0,0],[1,0],[1,1]]}' "$GRACE_URL/v1/polygons/classify" >"$out.code" &
  curl_pid=$!
  slow_job "$GRACE_URL" 30000   # queued behind it
  queued="$job_id"
  for i in $(seq 100); do
    curl -s "$GRACE_URL/metrics" | grep -qE '^lipmap_workers_busy 1$' && break
    sleep 0.05
  done
  start=$(date +%s%N)
  kill -TERM "$GRACE_PID"
  wait "$curl_pid"
  [ "$(cat "$out.code")" = 503 ]
  [ "$(jq -r .code "$out.body")" = shutting_down ]
  echo "schema problem.schema.json $out.body" >>"$BATS_TEST_TMPDIR/manifest"
  stop_server GRACE
  [ "$stop_status" = 0 ]
  elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
  [ "$elapsed_ms" -lt 10000 ] || { echo "shutdown took $elapsed_ms ms" >&2; return 1; }
}

@test "every setting from the environment (LIPMAP_*), and SIGINT drains like SIGTERM (exit 0)" {
  LIPMAP_WORKERS=1 LIPMAP_QUEUE=3 LIPMAP_MAX_BODY_BYTES=5000 LIPMAP_MAX_VERTICES=40 LIPMAP_DEADLINE=0.3 \
    LIPMAP_TEST_HOOKS=1 LIPMAP_LOG_LEVEL=warn start_server ENVS
  call GET "$ENVS_URL/metrics"
  grep -qE '^lipmap_workers 1$' "$answer"
  grep -qE '^lipmap_queue_capacity 3$' "$answer"
  call POST "$ENVS_URL/v1/parametrize" --json "@$(make_body grid12_square grid 12 square)"
  expect 413 payload_too_large
  call POST "$ENVS_URL/v1/parametrize" --json "@$(make_body grid7_square grid 7 square)"
  expect 422 mesh_too_large
  call POST "$ENVS_URL/v1/polygons/classify" -H 'X-Lipmap-Test-Delay-Ms: 3000' --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 504 deadline_exceeded
  # warn level: no per-request info lines
  ! grep -q '"event":"request","request_id".*"status":200' "$BATS_FILE_TMPDIR/ENVS.log"
  stop_server ENVS INT
  [ "$stop_status" = 0 ]
}

# The glibc tunables a process runs with, one per line, from its environment as exec'd (glibc's loader splits
# GLIBC_TUNABLES at its colons in place, so they read as NUL-separated entries there).
tunables_of() {
  tr '\0' '\n' < "/proc/$1/environ" | sed 's/^GLIBC_TUNABLES=//' | tr ':' '\n' | grep '^glibc\.' || true
}

@test "the service runs with its allocator and BLAS settings, and a setting the user named is kept" {
  # server/app/main.cpp adds what GLIBC_TUNABLES does not name and starts the binary again; read back from the
  # running process's own environment, not from the code that sets it.
  unset OPENBLAS_NUM_THREADS MALLOC_MMAP_THRESHOLD_ MALLOC_TRIM_THRESHOLD_
  GLIBC_TUNABLES= start_server TUNE
  local seen
  seen="$(tunables_of "$TUNE_PID")"
  grep -qx 'glibc.malloc.hugetlb=1' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  grep -qx 'glibc.malloc.mmap_threshold=33554432' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  grep -qx 'glibc.malloc.trim_threshold=1073741824' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  tr '\0' '\n' < "/proc/$TUNE_PID/environ" | grep -qx 'OPENBLAS_NUM_THREADS=1'
  call GET "$TUNE_URL/healthz"
  expect 200
  stop_server TUNE
  # named in GLIBC_TUNABLES, or by glibc's older variable (which GLIBC_TUNABLES would override)
  MALLOC_MMAP_THRESHOLD_=65536 GLIBC_TUNABLES=glibc.malloc.trim_threshold=4096 start_server OWN
  seen="$(tunables_of "$OWN_PID")"
  ! grep -q '^glibc.malloc.mmap_threshold=' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  grep -qx 'glibc.malloc.trim_threshold=4096' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  [ "$(grep -c '^glibc.malloc.trim_threshold=' <<< "$seen")" = 1 ] || { echo "tunables: $seen" >&2; return 1; }
  grep -qx 'glibc.malloc.hugetlb=1' <<< "$seen" || { echo "tunables: $seen" >&2; return 1; }
  stop_server OWN
}
