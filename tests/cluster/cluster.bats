#!/usr/bin/env bats
# Many replicas, one queue (docs/cluster.md): three `lipmap serve --queue-url` replicas behind nginx
# (round robin) share their jobs through Redis. Every answer is checked like tests/http's (problem shape,
# JSON Schemas, docs/contract.md for maps); results are compared byte for byte with a single process's.

load cluster

setup_file() { setup_cluster; }
teardown_file() { teardown_cluster; }

# A few different bodies, so that a job answered with another job's result would be caught.
bodies=(grid5_square:"grid 5 square" grid6_circle:"grid 6 circle" grid7_spiral:"grid 7 spiral"
        grid6_square_tutte:"grid 6 square --method tutte" grid8_circle:"grid 8 circle")
body_file() {  # body_file I: the body of job I
  local spec="${bodies[$(($1 % ${#bodies[@]}))]}"
  # shellcheck disable=SC2086
  make_body "${spec%%:*}" ${spec#*:}
}

@test "30 jobs through nginx: all succeed, each answer identical to a single process's for the same body (up to timings)" {
  local ids=() i id
  for i in $(seq 0 29); do
    id="$(submit "$NGINX_URL" "$(body_file "$i")")"
    ids+=("$id")
  done
  for i in $(seq 0 29); do
    [ "$(wait_final "$NGINX_URL" "${ids[$i]}" 120)" = succeeded ]
  done
  for i in $(seq 0 29); do
    # Polled through nginx: the replicas take turns answering, whichever ran the job.
    call -s job.schema.json GET "$NGINX_URL/v1/jobs/${ids[$i]}"
    expect 200
    [ "$(jq -r .progress.fraction "$answer")" = 1 ]
    call GET "$NGINX_URL/v1/jobs/${ids[$i]}/result"
    expect 200
    same_answer "$answer" "$(reference "$(( i % ${#bodies[@]} ))" "$(body_file "$i")")"
    [ "$i" -ge 5 ] || check_map "$(body_file "$i")"
  done
  local ran=""
  for n in 1 2 3; do ran+=" replica $n: $(grep -c '"event":"job_started"' "$BATS_FILE_TMPDIR/replica$n.log")"; done
  echo "# jobs started by$ran" >&3
  # Every replica answered some of those polls, and the previews render on any of them.
  for n in 1 2 3; do
    url="REPLICA${n}_URL"
    call GET "${!url}/v1/jobs/${ids[0]}/preview.svg"
    expect 200
    [[ "$ctype" == image/svg+xml* ]]
    call GET "${!url}/v1/jobs/${ids[0]}"
    expect 200
  done
  # Results in glTF, rendered on a replica that may not have run the job, are the single process's.
  call GET "$REPLICA2_URL/v1/jobs/${ids[1]}/result" -H 'Accept: model/gltf-binary'
  expect 200
  cp "$answer" "$BATS_TEST_TMPDIR/cluster.glb"
  call POST "$SINGLE_URL/v1/parametrize" -H 'Accept: model/gltf-binary' --json "@$(body_file 1)"
  expect 200
  same_answer "$answer" "$BATS_TEST_TMPDIR/cluster.glb"
}

@test "SIGKILL of the replica running a long job: the job succeeds on another replica, no accepted job lost" {
  local long ids=() i victim
  long="$(submit "$NGINX_URL" "$(body_file 2)" -H 'X-Lipmap-Test-Delay-Ms: 4000')"
  for i in 0 1 2 3 4; do ids+=("$(submit "$NGINX_URL" "$(body_file "$i")" -H 'X-Lipmap-Test-Delay-Ms: 800')"); done
  # The long job starts first (the queue is first in, first out); its replica's only worker is busy with it.
  wait_until 30 bash -c "curl -s '$NGINX_URL/v1/jobs/$long' | jq -e '.state == \"running\"' >/dev/null"
  victim="$(running_replica_of_long)"
  stop_replica "$victim" KILL
  local killed_at=$SECONDS
  # Within the visibility timeout plus the job's run time (bounded generously: no timing is asserted).
  [ "$(wait_final "$NGINX_URL" "$long" 60)" = succeeded ]
  echo "# replica $victim killed; its job succeeded elsewhere $((SECONDS - killed_at)) s later (visibility ${CLUSTER_VISIBILITY} s + 4 s run)" >&3
  call GET "$NGINX_URL/v1/jobs/$long/result"
  expect 200
  same_answer "$answer" "$(reference 2 "$(body_file 2)")"
  for i in 0 1 2 3 4; do
    [ "$(wait_final "$NGINX_URL" "${ids[$i]}" 60)" = succeeded ]
    call GET "$NGINX_URL/v1/jobs/${ids[$i]}/result"
    expect 200
    same_answer "$answer" "$(reference "$i" "$(body_file "$i")")"
  done
  # A surviving replica says it took the job over.
  local total=0 n url v
  for n in 1 2 3; do
    [ "$n" = "$victim" ] && continue
    url="REPLICA${n}_URL"
    v="$(curl -sf "${!url}/metrics" | awk '$1 == "lipmap_jobs_reclaimed_total" {print $2}')"
    total=$((total + v))
  done
  [ "$total" -ge 1 ]
  start_replica "$victim"  # back for the next tests
}

# The replica whose log says it started the long job last (its worker runs it now).
running_replica_of_long() {
  local n
  for n in 1 2 3; do
    if grep '"event":"job_started"' "$BATS_FILE_TMPDIR/replica$n.log" | grep -q "\"job_id\":\"$long\""; then
      echo "$n"; return 0
    fi
  done
  return 1
}

@test "DELETE through a different replica cancels a running job, and a queued one" {
  local id runner other n
  id="$(submit "$REPLICA1_URL" "$(body_file 0)" -H 'X-Lipmap-Test-Delay-Ms: 20000')"
  wait_until 30 bash -c "curl -s '$REPLICA3_URL/v1/jobs/$id' | jq -e '.state == \"running\"' >/dev/null"
  long="$id"
  runner="$(running_replica_of_long)"
  for n in 1 2 3; do [ "$n" != "$runner" ] && { other="$n"; break; }; done
  # Two polls wait for the end (?wait=): one on the runner (woken when its worker ends the job) and one on the
  # third replica (which learns it from Redis).
  local third url waiters=()
  for n in 1 2 3; do [ "$n" != "$runner" ] && [ "$n" != "$other" ] && third="$n"; done
  for n in "$runner" "$third"; do
    url="REPLICA${n}_URL"
    curl -sS -o "$BATS_TEST_TMPDIR/waited$n" --max-time 60 "${!url}/v1/jobs/$id?wait=30" &
    waiters+=($!)
  done
  sleep 0.3
  url="REPLICA${other}_URL"
  call -s job.schema.json DELETE "${!url}/v1/jobs/$id"
  expect 202
  [ "$(jq -r .cancel_requested "$answer")" = true ]
  for n in "${waiters[@]}"; do wait "$n"; done
  for n in "$runner" "$third"; do
    [ "$(jq -r .state "$BATS_TEST_TMPDIR/waited$n")" = cancelled ]
    echo "schema job.schema.json $BATS_TEST_TMPDIR/waited$n" >>"$BATS_TEST_TMPDIR/manifest"
  done
  [ "$(wait_final "$REPLICA2_URL" "$id" 30)" = cancelled ]
  call -s job.schema.json GET "$REPLICA3_URL/v1/jobs/$id"
  [ "$(jq -r .error.code "$answer")" = cancelled ]
  call GET "$REPLICA1_URL/v1/jobs/$id/result"
  expect 409 job_cancelled
  # A finished job deleted on one replica is gone on every one.
  call DELETE "$REPLICA2_URL/v1/jobs/$id"
  expect 204
  for n in 1 2 3; do
    url="REPLICA${n}_URL"
    call GET "${!url}/v1/jobs/$id"
    expect 410 job_gone
  done
  # A queued job (every worker busy with a long one) cancelled through nginx ends at once.
  local busy=() q
  for n in 1 2 3; do busy+=("$(submit "$NGINX_URL" "$(body_file 0)" -H 'X-Lipmap-Test-Delay-Ms: 3000')"); done
  q="$(submit "$NGINX_URL" "$(body_file 1)")"
  call -s job.schema.json DELETE "$NGINX_URL/v1/jobs/$q"
  if [ "$code" = 200 ]; then
    [ "$(jq -r .state "$answer")" = cancelled ]
  else
    expect 202  # a worker had taken it meanwhile
  fi
  [ "$(wait_final "$NGINX_URL" "$q" 30)" = cancelled ]
  for id in "${busy[@]}"; do [ "$(wait_final "$NGINX_URL" "$id" 60)" = succeeded ]; done
  call GET "$NGINX_URL/v1/jobs/00000000000000000000000000000000"
  expect 404 job_not_found
}

@test "Redis restart mid-run: no replica crashes, 503 queue_unavailable meanwhile, the jobs resume" {
  local ids=() i n url
  for i in 0 1 2 3 4 5; do ids+=("$(submit "$NGINX_URL" "$(body_file "$i")" -H 'X-Lipmap-Test-Delay-Ms: 1000')"); done
  stop_redis
  call POST "$REPLICA1_URL/v1/jobs" --json "@$(body_file 0)"
  expect 503 queue_unavailable
  [ -n "$(header Retry-After)" ]
  call GET "$REPLICA2_URL/v1/jobs/${ids[0]}"
  expect 503 queue_unavailable
  call GET "$REPLICA3_URL/readyz"
  expect 503 queue_unavailable
  sleep 1  # a job or two finish while Redis is away (their replicas retry the write)
  start_redis
  for n in 1 2 3; do
    url="REPLICA${n}_URL"
    wait_until 30 curl -sf --max-time 2 "${!url}/readyz" -o /dev/null
  done
  local state resumed=0 ended=0
  for i in 0 1 2 3 4 5; do
    state="$(wait_final "$NGINX_URL" "${ids[$i]}" 90)"
    if [ "$state" = succeeded ]; then
      resumed=$((resumed + 1))
      call GET "$NGINX_URL/v1/jobs/${ids[$i]}/result"
      expect 200
      same_answer "$answer" "$(reference "$i" "$(body_file "$i")")"
    else
      # A job that could not resume says why.
      ended=$((ended + 1))
      call -s job.schema.json GET "$NGINX_URL/v1/jobs/${ids[$i]}"
      [ -n "$(jq -r '.error.code // empty' "$answer")" ]
    fi
  done
  echo "# after the Redis restart: $resumed jobs succeeded, $ended ended with a problem" >&3
  for n in 1 2 3; do replica_alive "$n"; done
  # Each replica counted Redis errors (and says so on /metrics), and is ready again.
  for n in 1 2 3; do
    url="REPLICA${n}_URL"
    v="$(curl -sf "${!url}/metrics" | awk '$1 == "lipmap_redis_errors_total" {print $2}')"
    [ "$v" -ge 1 ]
  done
}

@test "POST /v1/jobs to a replica whose own pool is full: 202 queued (the cluster-wide cap decides), run by a free replica" {
  REPLICA4_PORT="$(free_port)"
  export REPLICA4_PORT
  REPLICA_QUEUE=1 start_replica 4
  # Its one worker and its pool's one waiting place taken by synchronous requests that wait 4 s.
  local sync=() i id
  for i in 1 2; do
    curl -s -o /dev/null --max-time 60 --json "@$(body_file 0)" -H 'X-Lipmap-Test-Delay-Ms: 4000' \
      "$REPLICA4_URL/v1/parametrize" &
    sync+=($!)
  done
  wait_until 20 bash -c "curl -sf '$REPLICA4_URL/metrics' | grep -qx 'lipmap_queue_depth 1'"
  # The pool is full: synchronous work is refused there ...
  call POST "$REPLICA4_URL/v1/parametrize" --json "@$(body_file 0)"
  expect 503 queue_full
  # ... a job is not: it waits in the shared queue (cap 1, empty) for a replica with a free worker.
  call -s job.schema.json POST "$REPLICA4_URL/v1/jobs" --json "@$(body_file 3)"
  expect 202
  [ "$(jq -r .state "$answer")" = queued ]
  id="$(jq -r .id "$answer")"
  [ "$(wait_final "$NGINX_URL" "$id" 60)" = succeeded ]
  call GET "$REPLICA4_URL/v1/jobs/$id/result"
  expect 200
  same_answer "$answer" "$(reference 3 "$(body_file 3)")"
  wait "${sync[@]}"
  stop_replica 4
}

local_reads() { curl -sf "$1/metrics" | awk '$1 == "lipmap_local_result_reads_total" {print $2}'; }

@test "The replica that ran a job answers its result from memory, the same bytes; a DELETE elsewhere makes it 410 there too" {
  local id runner other n before other_before url other_url
  id="$(submit "$NGINX_URL" "$(body_file 4)")"
  [ "$(wait_final "$NGINX_URL" "$id" 60)" = succeeded ]
  long="$id"
  runner="$(running_replica_of_long)"
  for n in 1 2 3; do [ "$n" != "$runner" ] && { other="$n"; break; }; done
  url="REPLICA${runner}_URL" other_url="REPLICA${other}_URL"
  [ "$(curl -sf "${!url}/metrics" | awk '$1 == "lipmap_local_results" {print $2}')" -ge 1 ]
  before="$(local_reads "${!url}")" other_before="$(local_reads "${!other_url}")"
  call GET "${!url}/v1/jobs/$id/result"
  expect 200
  [ "$(local_reads "${!url}")" = $((before + 1)) ]
  cp "$answer" "$BATS_TEST_TMPDIR/from_memory.json"
  # Another replica reads it from Redis: the same bytes.
  call GET "${!other_url}/v1/jobs/$id/result"
  expect 200
  [ "$(local_reads "${!other_url}")" = "$other_before" ]
  cmp "$answer" "$BATS_TEST_TMPDIR/from_memory.json"
  same_answer "$answer" "$(reference 4 "$(body_file 4)")"
  # Deleted through another replica: the runner's memory does not outlive the job.
  call DELETE "${!other_url}/v1/jobs/$id"
  expect 204
  call GET "${!url}/v1/jobs/$id/result"
  expect 410 job_gone
  [ "$(local_reads "${!url}")" = $((before + 1)) ]
}

started_on_submit() { curl -sf "$1/metrics" | awk '$1 == "lipmap_jobs_started_on_submit_total" {print $2}'; }
# started_by ID: the numbers of the replicas whose log says they started job ID.
started_by() {
  local n
  for n in 1 2 3; do
    grep '"event":"job_started"' "$BATS_FILE_TMPDIR/replica$n.log" | grep -q "\"job_id\":\"$1\"" && echo "$n"
  done
  return 0
}
# idle URL: the replica's worker is free and no job waits in the stream (a job accepted now starts there).
idle() { curl -sf "$1/metrics" | grep -x -e 'lipmap_workers_busy 0' -e 'lipmap_shared_queue_depth 0' | wc -l | grep -qx 2; }

@test "A job accepted by a replica with a free worker starts there at once; with that worker busy, another replica runs it" {
  local n url before id long other
  for n in 1 2 3; do url="REPLICA${n}_URL"; wait_until 60 idle "${!url}"; done
  before="$(started_on_submit "$REPLICA1_URL")"
  # Replica 1 is idle: the job runs there, started by the submit itself (not through the stream's fetcher).
  id="$(submit "$REPLICA1_URL" "$(body_file 1)")"
  [ "$(wait_final "$NGINX_URL" "$id" 60)" = succeeded ]
  [ "$(started_on_submit "$REPLICA1_URL")" = $((before + 1)) ]
  [ "$(started_by "$id")" = 1 ]
  grep '"event":"job_started"' "$BATS_FILE_TMPDIR/replica1.log" | grep "\"job_id\":\"$id\"" | grep -q '"on_submit":true'
  call GET "$REPLICA2_URL/v1/jobs/$id/result"
  expect 200
  same_answer "$answer" "$(reference 1 "$(body_file 1)")"
  # Replica 1's only worker busy with a long job (started there too): the next job it accepts waits in the
  # stream, and one of the idle replicas runs it.
  wait_until 30 idle "$REPLICA1_URL"
  long="$(submit "$REPLICA1_URL" "$(body_file 0)" -H 'X-Lipmap-Test-Delay-Ms: 4000')"
  [ "$(started_on_submit "$REPLICA1_URL")" = $((before + 2)) ]
  other="$(submit "$REPLICA1_URL" "$(body_file 3)")"
  [ "$(wait_final "$NGINX_URL" "$other" 60)" = succeeded ]
  n="$(started_by "$other")"
  [ "$n" = 2 ] || [ "$n" = 3 ]
  [ "$(started_on_submit "$REPLICA1_URL")" = $((before + 2)) ]
  call GET "$NGINX_URL/v1/jobs/$other/result"
  expect 200
  same_answer "$answer" "$(reference 3 "$(body_file 3)")"
  [ "$(wait_final "$NGINX_URL" "$long" 60)" = succeeded ]
  [ "$(started_by "$long")" = 1 ]
  call GET "$NGINX_URL/v1/jobs/$long/result"
  expect 200
  same_answer "$answer" "$(reference 0 "$(body_file 0)")"
}
