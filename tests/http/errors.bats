#!/usr/bin/env bats
# `lipmap serve` with bad input of every kind: each error class gets its RFC 7807 problem (status, stable
# type/code, pointer/element/index where they apply), validated against proto/problem.schema.json, and the
# service keeps serving everyone else. No request may make it answer 5xx other than 500 (internal bug, here
# only through the test hook), 503 or 504.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() { serve_for_file MAIN --workers 2 --queue 16 --test-hooks; }

teardown_file() { stop_server MAIN; }

# post ENDPOINT BODY: POST a JSON body given as a string.
post() {
  call POST "$MAIN_URL$1" -H 'Content-Type: application/json' --data-binary "$2"
}

pointer_is() { [ "$(jq -r .pointer "$answer")" = "$1" ] || { echo "pointer $(jq -r .pointer "$answer"), wanted $1" >&2; return 1; }; }

GOOD_MESH='"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0.5,0.5,0.2]], "faces": [[0,1,4],[1,2,4],[2,3,4],[3,0,4]]}'
GOOD_BOUNDARY='"boundary": {"positions": [[0,0],[2,0],[2,2],[0,2]]}'

# ---- malformed JSON, wrong shapes: 400 ----------------------------------------------------------------

@test "malformed JSON: 400 invalid_json with the byte offset, on every POST endpoint" {
  for ep in /v1/parametrize /v1/jobs /v1/polygons/classify; do
    post "$ep" '{"mesh": {"vertices": [[0,0,0],'
    expect 400 invalid_json
    [ "$(jq -r .byte_offset "$answer")" -gt 0 ]
  done
  post /v1/parametrize ''
  expect 400 invalid_json
  post /v1/parametrize '{"a": 1} trailing'
  expect 400 invalid_json
}

@test "binary garbage and invalid UTF-8: 400 invalid_json" {
  head -c 8192 /dev/urandom >"$BATS_TEST_TMPDIR/garbage"
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' --data-binary "@$BATS_TEST_TMPDIR/garbage"
  expect 400 invalid_json
  printf '{"polygon": [[0,0],[1,0],[1,1]], "\xff\xfe": 1}' >"$BATS_TEST_TMPDIR/utf8"
  call POST "$MAIN_URL/v1/polygons/classify" -H 'Content-Type: application/json' --data-binary "@$BATS_TEST_TMPDIR/utf8"
  expect 400 invalid_json
}

@test "wrong types: 400 wrong_type with the JSON pointer of the value" {
  post /v1/parametrize '{"mesh": {"vertices": "many", "faces": []}, '"$GOOD_BOUNDARY"'}'
  expect 400 wrong_type
  pointer_is /mesh/vertices
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,"0"],[1,1,0]], "faces": [[0,1,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 wrong_type
  pointer_is /mesh/vertices/1/2
  post /v1/parametrize '{'"$GOOD_MESH"', "boundary": {"positions": [[0,0],[2,0],[2,true],[0,2]]}}'
  expect 400 wrong_type
  pointer_is /boundary/positions/2/1
  post /v1/parametrize '[1, 2, 3]'
  expect 400 wrong_type
  post /v1/parametrize '{'"$GOOD_MESH"', '"$GOOD_BOUNDARY"', "options": {"method": 7}}'
  expect 400 wrong_type
  pointer_is /options/method
}

@test "missing, unknown and misshapen fields: 400 missing_field, unknown_field, wrong_length, not_an_integer, invalid_value" {
  post /v1/parametrize '{'"$GOOD_MESH"'}'
  expect 400 missing_field
  pointer_is /boundary
  post /v1/parametrize '{'"$GOOD_MESH"', '"$GOOD_BOUNDARY"', "option": {}}'
  expect 400 unknown_field
  pointer_is /option
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0],[1,1,0]], "faces": [[0,1,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 wrong_length
  pointer_is /mesh/vertices/1
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0]], "faces": [[0,1.5,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 not_an_integer
  pointer_is /mesh/faces/0/1
  post /v1/parametrize '{'"$GOOD_MESH"', '"$GOOD_BOUNDARY"', "options": {"method": "lscm"}}'
  expect 400 invalid_value
  post /v1/parametrize '{'"$GOOD_MESH"', '"$GOOD_BOUNDARY"', "mesh": {}}'
  expect 400 duplicate_key
}

@test "NaN and infinite coordinates: 400 (NaN/Infinity are not JSON; 1e999 is non_finite_number with its pointer)" {
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,NaN,0],[1,1,0]], "faces": [[0,1,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 invalid_json
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,Infinity,0],[1,1,0]], "faces": [[0,1,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 invalid_json
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,-1e999]], "faces": [[0,1,2]]}, '"$GOOD_BOUNDARY"'}'
  expect 400 non_finite_number
  pointer_is /mesh/vertices/2/2
  post /v1/parametrize '{'"$GOOD_MESH"', "boundary": {"positions": [[0,0],[2,0],[2,2],[1e400,2]]}}'
  expect 400 non_finite_number
  pointer_is /boundary/positions/3/0
  post /v1/polygons/classify '{"polygon": [[0,0],[1,0],[1,1e999]]}'
  expect 400 non_finite_number
  pointer_is /polygon/2/1
}

@test "absurd nesting and huge numbers: 400, no crash" {
  body="$(printf '[%.0s' $(seq 20000))"
  post /v1/parametrize "$body"
  expect 400 nesting_too_deep
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0]], "faces": [[0,1,99999999999999999999999]]}, '"$GOOD_BOUNDARY"'}'
  [ "$code" = 400 ] || [ "$code" = 422 ]
  call GET "$MAIN_URL/healthz"
  expect 200
}

# ---- invalid meshes and boundaries: 422 with the validate stage's code -------------------------------------

@test "out-of-range indices: 422 face_index_out_of_range naming the face; boundary vertex out of range" {
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "faces": [[0,1,2],[0,2,7]]}, '"$GOOD_BOUNDARY"'}'
  expect 422 face_index_out_of_range
  pointer_is /mesh/faces/1
  [ "$(jq -r .element "$answer")" = face ]
  [ "$(jq -r .index "$answer")" = 1 ]
  post /v1/parametrize '{"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "faces": [[0,1,2],[0,-1,3]]}, '"$GOOD_BOUNDARY"'}'
  expect 422 face_index_out_of_range
  post /v1/parametrize '{'"$GOOD_MESH"', "boundary": {"vertices": [0,1,2,42], "positions": [[0,0],[2,0],[2,2],[0,2]]}}'
  expect 422 boundary_vertex_out_of_range
  pointer_is /boundary/vertices/3
}

@test "non-manifold, not a disk, closed, two boundary loops: 422 with the validate code" {
  for kind in nonmanifold:non_manifold_edge torus:not_a_disk closed:no_boundary annulus:multiple_boundary_loops; do
    call POST "$MAIN_URL/v1/parametrize" --json "@$(make_body "invalid_${kind%%:*}" invalid "${kind%%:*}")"
    expect 422 "${kind##*:}"
    [ "$(jq -r .title "$answer")" = "Invalid mesh" ]
  done
}

@test "a boundary of the wrong length: 422 boundary_length_mismatch at /boundary/positions" {
  post /v1/parametrize '{'"$GOOD_MESH"', "boundary": {"positions": [[0,0],[2,0],[2,2]]}}'
  expect 422 boundary_length_mismatch
  pointer_is /boundary/positions
  [ "$(jq -r .title "$answer")" = "Invalid boundary" ]
}

@test "a boundary that is not self-overlapping: 422 not_self_overlapping carrying the verdict and turning number" {
  call POST "$MAIN_URL/v1/parametrize" --json "@$(make_body grid6_clockwise grid 6 clockwise)"
  expect 422 not_self_overlapping
  [ "$(jq -r .verdict "$answer")" = not_self_overlapping ]
  [ "$(jq -r .turning_number "$answer")" = -1 ]
  [ -n "$(jq -r .reason "$answer")" ]
  call POST "$MAIN_URL/v1/parametrize" --json "@$(make_body grid6_figure8 grid 6 figure8)"
  expect 422 not_self_overlapping
  [ "$(jq -r .turning_number "$answer")" = 0 ]
  # as a job: state failed with the same problem
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" --json "@$(make_body grid6_figure8 grid 6 figure8)"
  expect 202
  wait_for_job "$MAIN_URL" "$(jq -r .id "$answer")" failed
  [ "$(jq -r .error.code "$answer")" = not_self_overlapping ]
}

@test "classify: engine errors are 422 with the polygon vertex" {
  post /v1/polygons/classify '{"polygon": [[0,0],[1,0]]}'
  expect 422 polygon_too_small
  post /v1/polygons/classify '{"polygon": [[0,0],[1,0],[1,0],[0,1]]}'
  expect 422 polygon_zero_length_edge
  post /v1/polygons/classify '{"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0,99,0]}'
  expect 422 rotation_index_out_of_range
  pointer_is /rotation_indices/1
}

# ---- transport: media type, routes, methods, framing --------------------------------------------------------

@test "unsupported media type: 415 with Accept-Post, for text, XML, forms and a missing Content-Type" {
  for ep in /v1/parametrize /v1/jobs /v1/polygons/classify; do
    for type in text/plain application/xml; do
      call POST "$MAIN_URL$ep" -H "Content-Type: $type" --data-binary '{"polygon": [[0,0],[1,0],[1,1]]}'
      expect 415 unsupported_media_type
      [[ "$(header Accept-Post)" == *application/json* ]]
      [ "$(jq -r '.supported | index("application/json")' "$answer")" != null ]
    done
  done
  call POST "$MAIN_URL/v1/polygons/classify" --data '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 415 unsupported_media_type
  # glTF is taken by the mapping endpoints (tests/http/gltf.bats), not by classify
  call POST "$MAIN_URL/v1/polygons/classify" -H 'Content-Type: model/gltf-binary' --data-binary 'glTF'
  expect 415 unsupported_media_type
  call POST "$MAIN_URL/v1/polygons/classify" -H 'Content-Type:' --data-binary '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 415 unsupported_media_type
}

@test "unknown route: 404 not_found; wrong method: 405 with Allow; no length or chunked: 411" {
  call GET "$MAIN_URL/v2/parametrize"
  expect 404 not_found
  call GET "$MAIN_URL/"
  expect 404 not_found
  call GET "$MAIN_URL/v1/parametrize"
  expect 405 method_not_allowed
  [ "$(header Allow)" = POST ]
  call DELETE "$MAIN_URL/healthz"
  expect 405 method_not_allowed
  [ "$(header Allow)" = "GET, HEAD" ]
  call PUT "$MAIN_URL/v1/jobs/0123456789abcdef0123456789abcdef" --json '{}'
  expect 405 method_not_allowed
  call POST "$MAIN_URL/v1/parametrize"
  expect 411 length_required
  call POST "$MAIN_URL/v1/parametrize" -H 'Transfer-Encoding: chunked' --json '{"mesh": {}}'
  expect 411 length_required
}

@test "raw garbage on the socket: the connection gets a 400 or is closed, the service keeps serving" {
  port="${MAIN_URL##*:}"
  for payload in $'GARBAGE\r\n\r\n' $'GET / HTTP/9.9\r\n\r\n' $'\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03' \
                 "GET /$(head -c 20000 /dev/zero | tr '\0' a) HTTP/1.1"$'\r\nHost: x\r\n\r\n' \
                 $'POST /v1/parametrize HTTP/1.1\r\nContent-Length: -5\r\n\r\n' \
                 $'POST /v1/parametrize HTTP/1.1\r\nContent-Length: 99999999999999999999\r\nContent-Type: application/json\r\n\r\n{}'; do
    # an answer, a close, or (for bytes that never finish a request) nothing until we give up after 2 s
    timeout 2 bash -c 'exec 3<>/dev/tcp/127.0.0.1/$1; printf "%s" "$2" >&3; head -c 4096 <&3 >/dev/null || true' _ "$port" "$payload" || true
  done
  call GET "$MAIN_URL/healthz"
  expect 200
}

@test "internal errors are 500 with the reason, out of memory is 503; the service survives both" {
  call POST "$MAIN_URL/v1/polygons/classify" -H 'X-Lipmap-Test-Fault: internal' --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 500 internal_error
  [[ "$(jq -r .detail "$answer")" == *"injected fault"* ]]
  call POST "$MAIN_URL/v1/parametrize" -H 'X-Lipmap-Test-Fault: exception' --json "@$(make_body grid4_square grid 4 square)"
  expect 500 internal_error
  call POST "$MAIN_URL/v1/parametrize" -H 'X-Lipmap-Test-Fault: bad_alloc' --json "@$(make_body grid4_square grid 4 square)"
  expect 503 out_of_memory
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" -H 'X-Lipmap-Test-Fault: internal' --json "@$(make_body grid4_square grid 4 square)"
  wait_for_job "$MAIN_URL" "$(jq -r .id "$answer")" failed
  [ "$(jq -r .error.status "$answer")" = 500 ]
  call POST "$MAIN_URL/v1/polygons/classify" --json '{"polygon": [[0,0],[1,0],[1,1]]}'
  expect 200
}

@test "a burst of bounded random bad bodies: only 4xx problems, then the service still maps" {
  good="$(cat "$(make_body grid6_square grid 6 square)")"
  len=${#good}
  for i in $(seq 40); do
    case $((i % 4)) in
      0) body="${good:0:$((RANDOM % len))}" ;;                             # truncated
      1) body="$(head -c $((RANDOM % 2000 + 1)) /dev/urandom | base64 -w0)" ;;  # noise
      2) body="${good/0.2/\"x\"}" ;;                                        # a string where a number goes
      3) body="${good/[[0,1,/[[0,$((RANDOM * 1000)),}" ;;                  # an index far out of range
    esac
    post /v1/parametrize "$body"
    [[ "$code" =~ ^4[0-9][0-9]$ ]] || { echo "body $i: HTTP $code" >&2; return 1; }
  done
  call POST "$MAIN_URL/v1/parametrize" --json "@$(make_body grid6_square grid 6 square)"
  expect 200
  check_map "$(make_body grid6_square grid 6 square)"
}

# ---- limits (their own servers) ---------------------------------------------------------------------------

@test "body over the limit: 413 payload_too_large with the limit; smaller bodies still served" {
  start_server SMALL --workers 1 --max-body-bytes 4096
  req="$(make_body grid12_square grid 12 square)"
  call POST "$SMALL_URL/v1/parametrize" --json "@$req"
  expect 413 payload_too_large
  [ "$(jq -r .limit_bytes "$answer")" = 4096 ]
  head -c 3000000 /dev/zero | tr '\0' ' ' >"$BATS_TEST_TMPDIR/big.json"
  call POST "$SMALL_URL/v1/polygons/classify" --json "@$BATS_TEST_TMPDIR/big.json"
  expect 413 payload_too_large
  call POST "$SMALL_URL/v1/parametrize" --json "@$(make_body grid4_square grid 4 square)"
  expect 200
  stop_server SMALL
  [ "$stop_status" = 0 ]
}

@test "mesh and polygon size limits: 422 mesh_too_large / polygon_too_large naming the array" {
  start_server LIMITS --workers 1 --max-vertices 50 --max-faces 200 --max-polygon-vertices 30
  call POST "$LIMITS_URL/v1/parametrize" --json "@$(make_body grid8_square grid 8 square)"
  expect 422 mesh_too_large
  [ "$(jq -r .pointer "$answer")" = /mesh/vertices ]
  call POST "$LIMITS_URL/v1/jobs" --json "@$(make_body grid8_square grid 8 square)"
  expect 422 mesh_too_large
  call POST "$LIMITS_URL/v1/polygons/classify" --json "@$(make_body poly_circle40 polygon circle 40)"
  expect 422 polygon_too_large
  [ "$(jq -r .pointer "$answer")" = /polygon ]
  call POST "$LIMITS_URL/v1/parametrize" --json "@$(make_body grid6_square grid 6 square)"
  expect 200
  stop_server LIMITS
}

@test "metrics count the errors by route and status" {
  post /v1/polygons/classify '{"polygon": '
  call GET "$MAIN_URL/metrics"
  expect 200
  grep -qE '^lipmap_http_requests_total\{route="/v1/polygons/classify",method="POST",status="400"\} [1-9]' "$answer"
  grep -qE '^lipmap_http_requests_total\{route="unmatched",method="GET",status="404"\} [1-9]' "$answer"
  # nothing answered 5xx except the injected faults (500, 503 out_of_memory)
  ! grep -E '^lipmap_http_requests_total\{.*status="5(0[1-2]|0[5-9]|[1-9][0-9])"\}' "$answer"
}
