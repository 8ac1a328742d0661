#!/usr/bin/env bats
# `lipmap serve`, the real binary on a free loopback port: every endpoint with good input. Every answer is
# validated against proto/ and every map against docs/contract.md (helpers/check_answers.js, in teardown).

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() { serve_for_file MAIN --workers 2 --queue 16; }

teardown_file() { stop_server MAIN; }

# log_line REQUEST_ID: the MAIN service's log line for that request (it is written after the answer: waits up
# to 5 s for it).
log_line() {
  local line="" i
  for i in $(seq 50); do
    line="$(grep "\"request_id\":\"$1\"" "$BATS_FILE_TMPDIR/MAIN.log" || true)"
    [ -n "$line" ] && break
    sleep 0.1
  done
  printf '%s\n' "$line"
}

# ---- probes, metrics, documents -------------------------------------------------------------------------

@test "GET /healthz and /readyz: 200 text, with an X-Request-Id" {
  call GET "$MAIN_URL/healthz"
  expect 200
  [ "$body" = ok ]
  [[ "$ctype" == text/plain* ]]
  [[ "$(header X-Request-Id)" =~ ^[0-9a-f]{16}$ ]]
  call GET "$MAIN_URL/readyz"
  expect 200
  [ "$body" = ready ]
  call HEAD "$MAIN_URL/healthz"
  expect 200
}

@test "a second service on the same port fails at once (exit 1, listen_failed) and takes none of its traffic" {
  port="${MAIN_URL##*:}"
  run --separate-stderr "$LIPMAP" serve --host 127.0.0.1 --port "$port"
  [ "$status" -eq 1 ]
  [[ "$stderr" == "lipmap: error: listen_failed: "* ]]
  call GET "$MAIN_URL/healthz"
  expect 200
}

@test "a sane incoming X-Request-Id is kept, a bad one replaced" {
  call GET "$MAIN_URL/healthz" -H 'X-Request-Id: build-42.step:7'
  [ "$(header X-Request-Id)" = build-42.step:7 ]
  call GET "$MAIN_URL/healthz" -H 'X-Request-Id: no spaces <allowed>'
  [[ "$(header X-Request-Id)" =~ ^[0-9a-f]{16}$ ]]
}

@test "GET /v1/openapi.json: the document of proto/, byte for byte; its schemas are served beside it" {
  call GET "$MAIN_URL/v1/openapi.json"
  expect 200
  [[ "$ctype" == application/json* ]]
  cmp "$answer" "$HTTP_ROOT/proto/openapi.json"
  for f in "$HTTP_ROOT"/proto/*.schema.json; do
    call GET "$MAIN_URL/v1/$(basename "$f")"
    expect 200
    cmp "$answer" "$f"
  done
  call GET "$MAIN_URL/v1/nope.schema.json"
  expect 404 not_found
}

@test "GET /version: the name and the version that CMakeLists.txt gives the project" {
  want="$(sed -nE 's/^project\(lipmap VERSION ([0-9][0-9.]*).*/\1/p' "$HTTP_ROOT/CMakeLists.txt")"
  [ -n "$want" ]
  call GET "$MAIN_URL/version"
  expect 200
  [[ "$ctype" == application/json* ]]
  jq -e --arg v "$want" '. == {"name": "lipmap", "version": $v}' "$answer"
  call HEAD "$MAIN_URL/version"
  expect 200
  call POST "$MAIN_URL/version" --json '{}'
  expect 405 method_not_allowed
  [ "$(header Allow)" = "GET, HEAD" ]
}

@test "GET /metrics: Prometheus text with requests, latency, queue, jobs, stage times, inserted vertices" {
  call GET "$MAIN_URL/healthz"
  call GET "$MAIN_URL/metrics"
  expect 200
  [[ "$ctype" == "text/plain; version=0.0.4"* ]]
  echo "metrics $answer" >>"$BATS_TEST_TMPDIR/manifest"
  grep -qE '^lipmap_http_requests_total\{route="/healthz",method="GET",status="200"\} [1-9]' "$answer"
  grep -qE '^lipmap_http_request_duration_seconds_bucket\{route="/healthz",le="\+Inf"\} [1-9]' "$answer"
  grep -qE '^lipmap_queue_depth 0$' "$answer"
  grep -qE '^lipmap_workers 2$' "$answer"
  grep -qE '^lipmap_jobs\{state="running"\} ' "$answer"
}

# ---- classify --------------------------------------------------------------------------------------------

@test "POST /v1/polygons/classify: every sample polygon, same answer as the CLI (up to timings)" {
  for f in "$HTTP_ROOT"/tests/data/polygons/*.json; do
    call -s classify-answer.schema.json POST "$MAIN_URL/v1/polygons/classify" --json "@$f"
    expect 200
    cli="$("$LIPMAP" classify "$f" | jq -c 'del(.diagnostics.timings_ms)')"
    [ "$(jq -c 'del(.diagnostics.timings_ms)' "$answer")" = "$cli" ] || { echo "$f differs from the CLI" >&2; return 1; }
  done
}

@test "classify: spiral is self_overlapping, clockwise and figure-eight are answers too (200)" {
  call -s classify-answer.schema.json POST "$MAIN_URL/v1/polygons/classify" --json "@$(make_body poly_spiral polygon spiral 40)"
  expect 200
  [ "$(jq -r .verdict "$answer")" = self_overlapping ]
  call -s classify-answer.schema.json POST "$MAIN_URL/v1/polygons/classify" --json "@$(make_body poly_cw polygon clockwise 12)"
  expect 200
  [ "$(jq -r .verdict "$answer")" = not_self_overlapping ]
  [ "$(jq -r .turning_number "$answer")" = -1 ]
}

# ---- parametrize (synchronous) ------------------------------------------------------------------------------

@test "POST /v1/parametrize: a grid onto a square (simple), the map passes the checks of docs/contract.md" {
  req="$(make_body grid8_square grid 8 square)"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req"
  expect 200
  check_map "$req"
  [ "$(jq -r .verdict "$answer")" = simple ]
  [ "$(jq -r .diagnostics.flipped "$answer")" = 0 ]
}

@test "parametrize: a grid onto an annulus sector wound 1.25 turns (self-overlapping): refined, valid" {
  req="$(make_body grid16_spiral grid 16 spiral)"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req"
  expect 200
  check_map "$req"
  [ "$(jq -r .verdict "$answer")" = self_overlapping ]
  [ "$(jq -r '.inserted | length' "$answer")" = "$(jq -r .diagnostics.inserted_vertices "$answer")" ]
}

@test "parametrize: harmonic and tutte methods, circle boundary" {
  for method in harmonic tutte; do
    req="$(make_body "grid12_circle_$method" grid 12 circle --method "$method")"
    call POST "$MAIN_URL/v1/parametrize" --json "@$req"
    expect 200
    check_map "$req"
  done
}

@test "parametrize: a real mesh (nefertiti.off, 562 triangles) onto a circle" {
  mesh="$HTTP_ROOT/tests/data/meshes/nefertiti.off"
  req="$(make_body nefertiti mesh "$mesh" circle)"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req"
  expect 200
  check_map "$req"
}

@test "parametrize: Content-Type with a charset parameter is accepted" {
  req="$(make_body grid4_square grid 4 square)"
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json; charset=utf-8' --data-binary "@$req"
  expect 200
  check_map "$req"
}

@test "parametrize: Server-Timing names parse, queue, engine and answer; engine is the answer's own total" {
  req="$(make_body grid10_spiral_timing grid 10 spiral)"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req" -H 'X-Request-Id: timing-probe-1'
  expect 200
  timing="$(header Server-Timing)"
  [[ "$timing" =~ ^parse\;dur=[0-9]+\.[0-9],\ queue\;dur=[0-9]+\.[0-9],\ engine\;dur=[0-9]+\.[0-9],\ answer\;dur=[0-9]+\.[0-9]$ ]]
  engine="$(sed -E 's/.*engine;dur=([0-9.]+).*/\1/' <<<"$timing")"
  total="$(jq .diagnostics.timings_ms.total "$answer")"
  # the header rounds to 0.1 ms
  awk -v a="$engine" -v b="$total" 'BEGIN { d = a - b; exit !(d <= 0.05 && d >= -0.05) }'
  # and the request log carries the same engine time
  line="$(log_line timing-probe-1)"
  jq -e --argjson t "$total" '(.engine_ms - $t) | fabs < 0.001' <<<"$line"
  # a refused body went through parsing only
  call POST "$MAIN_URL/v1/parametrize" --json '{"mesh": 1}'
  expect 400 wrong_type
  [[ "$(header Server-Timing)" =~ ^parse\;dur=[0-9]+\.[0-9]$ ]]
}

# ---- jobs ----------------------------------------------------------------------------------------------

@test "jobs: POST -> 202 + Location, poll to succeeded with progress by stage, result = the synchronous answer" {
  req="$(make_body grid20_spiral grid 20 spiral)"
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$req"
  expect 202
  id="$(jq -r .id "$answer")"
  [ "$(header Location)" = "/v1/jobs/$id" ]
  [[ "$(jq -r .state "$answer")" =~ ^(queued|running|succeeded)$ ]]
  wait_for_job "$MAIN_URL" "$id" succeeded
  [ "$(jq -r .progress.fraction "$answer")" = 1 ]
  [ "$(jq -r '[.progress.stages[].stage] | join(",")' "$answer")" = \
    validate,classify,target_mesh,intermediate_maps,compose,untangle,refine,optimize,verify,quality ]
  [ "$(jq -r '[.progress.stages[].done] | all' "$answer")" = true ]
  call GET "$MAIN_URL/v1/jobs/$id/result"
  expect 200
  check_map "$req"
  job_result="$(jq -c 'del(.diagnostics.timings_ms)' "$answer")"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req"
  expect 200
  [ "$(jq -c 'del(.diagnostics.timings_ms)' "$answer")" = "$job_result" ]
}

@test "jobs: GET /v1/jobs/{id}/preview.svg draws the finished map" {
  req="$(make_body grid10_spiral grid 10 spiral)"
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$req"
  id="$(jq -r .id "$answer")"
  wait_for_job "$MAIN_URL" "$id" succeeded
  call GET "$MAIN_URL/v1/jobs/$id/preview.svg"
  expect 200
  [[ "$ctype" == image/svg+xml* ]]
  grep -q '<svg' "$answer"
  grep -q 'id="triangles"' "$answer"
  grep -q '</svg>' "$answer"
  # the second time it comes from the job's cache: same bytes
  cp "$answer" "$BATS_TEST_TMPDIR/first.svg"
  call GET "$MAIN_URL/v1/jobs/$id/preview.svg"
  cmp "$answer" "$BATS_TEST_TMPDIR/first.svg"
}

@test "jobs: a failed job (invalid mesh) is state failed with the 422 problem; its result is 409 job_failed" {
  req="$(make_body invalid_torus invalid torus)"
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$req"
  expect 202
  id="$(jq -r .id "$answer")"
  wait_for_job "$MAIN_URL" "$id" failed
  [ "$(jq -r .error.code "$answer")" = not_a_disk ]
  [ "$(jq -r .error.status "$answer")" = 422 ]
  call GET "$MAIN_URL/v1/jobs/$id/result"
  expect 409 job_failed
  [ "$(jq -r .cause.code "$answer")" = not_a_disk ]
  call GET "$MAIN_URL/v1/jobs/$id/preview.svg"
  expect 409 job_failed
}

@test "jobs: a body that does not parse is refused at once (400), no job is made" {
  call POST "$MAIN_URL/v1/jobs" --json '{"mesh": '
  expect 400 invalid_json
  [ -z "$(header Location)" ]
}

@test "jobs: DELETE of a finished job drops it: 204, then 410 job_gone (reason deleted); unknown ids are 404" {
  req="$(make_body grid4_square grid 4 square)"
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$req"
  id="$(jq -r .id "$answer")"
  wait_for_job "$MAIN_URL" "$id" succeeded
  call DELETE "$MAIN_URL/v1/jobs/$id"
  expect 204
  call GET "$MAIN_URL/v1/jobs/$id"
  expect 410 job_gone
  [ "$(jq -r .reason "$answer")" = deleted ]
  call GET "$MAIN_URL/v1/jobs/$id/result"
  expect 410 job_gone
  call DELETE "$MAIN_URL/v1/jobs/$id"
  expect 410 job_gone
  call GET "$MAIN_URL/v1/jobs/0123456789abcdef0123456789abcdef"
  expect 404 job_not_found
  call GET "$MAIN_URL/v1/jobs/not-an-id"
  expect 404 job_not_found
  call GET "$MAIN_URL/v1/jobs/0123456789abcdef0123456789abcdef/result"
  expect 404 job_not_found
}

@test "the request log: one JSON line per request with its id, route, status and time" {
  call GET "$MAIN_URL/healthz" -H 'X-Request-Id: log-probe-1'
  line="$(log_line log-probe-1)"
  jq -e '.event == "request" and .route == "/healthz" and .status == 200 and .method == "GET" and (.ms | type) == "number" and (.ts | test("Z$"))' <<<"$line"
  # every line of the log is JSON
  while IFS= read -r l; do jq -e . <<<"$l" >/dev/null || { echo "not JSON: $l" >&2; return 1; }; done <"$BATS_FILE_TMPDIR/MAIN.log"
}

@test "the check tools have teeth: a flipped face, a moved boundary uv and a job with a bad state are refused" {
  req="$(make_body grid8_spiral grid 8 spiral)"
  call POST "$MAIN_URL/v1/parametrize" --json "@$req"
  expect 200
  jq -c '.mesh.faces[0] |= [.[0], .[2], .[1]]' "$answer" >"$BATS_TEST_TMPDIR/flipped.json"
  jq -c '.uv[.boundary_loop[0]][0] += 1e-9' "$answer" >"$BATS_TEST_TMPDIR/moved.json"
  echo "map $req $BATS_TEST_TMPDIR/flipped.json" >"$BATS_TEST_TMPDIR/bad1"
  echo "map $req $BATS_TEST_TMPDIR/moved.json" >"$BATS_TEST_TMPDIR/bad2"
  echo '{"id":"x","state":"done"}' >"$BATS_TEST_TMPDIR/job.json"
  echo "schema job.schema.json $BATS_TEST_TMPDIR/job.json" >"$BATS_TEST_TMPDIR/bad3"
  for m in bad1 bad2 bad3; do
    run node "$HELPERS/check_answers.js" "$BATS_TEST_TMPDIR/$m"
    [ "$status" -eq 1 ] || { echo "$m passed the checks" >&2; return 1; }
  done
  # and the project's own validator agrees on a real answer
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$req"
  node "$HTTP_ROOT/tests/tools/validate_json.js" job.schema.json "$answer"
}
