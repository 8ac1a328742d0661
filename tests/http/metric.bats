#!/usr/bin/env bats
# options.metric (paper 5.2, variable metric) through the HTTP service: a locally injective reference map comes
# back unchanged, a flipped one comes back without flips and close to it, glTF's metric=texcoord:N repairs a
# chart, and bad metrics get their problem (400 for the JSON shape, 422 for what the engine refuses), while the
# service keeps serving.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() {
  require_tools
  export TOOLS="$HTTP_ROOT/tests/tools" MESHES="$HTTP_ROOT/tests/data/meshes" FIX="$BATS_FILE_TMPDIR"
  node "$TOOLS/gltf_fixture.js" model "$MESHES/swirl_blob.obj" "$FIX/swirl_blob.glb"
  node "$TOOLS/gltf_fixture.js" target "$MESHES/swirl_blob.obj" exp "$FIX/swirl_blob_exp.json" 2>/dev/null
  start_server MAIN --workers 2 --queue 16
}

teardown_file() { stop_server MAIN; }

post() { call -s parametrize-answer.schema.json POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' --data-binary "$1"; }
pointer_is() { [ "$(jq -r .pointer "$answer")" = "$1" ] || { echo "pointer $(jq -r .pointer "$answer"), wanted $1" >&2; return 1; }; }

MESH='"mesh": {"vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0.5,0.5,0.2]], "faces": [[0,1,4],[1,2,4],[2,3,4],[3,0,4]]}'
BOUNDARY='"boundary": {"positions": [[0,0],[2,0],[2,2],[0,2]]}'
body() { echo '{'"$MESH, $BOUNDARY"', "options": {"metric": '"$1"'}}'; }

@test "a locally injective reference map comes back unchanged, nothing inserted" {
  post "$(body '{"uv": [[0,0],[2,0],[2,2],[0,2],[1.3,0.6]]}')"
  expect 200
  [ "$(jq -c '.uv' "$answer")" = '[[0,0],[2,0],[2,2],[0,2],[1.3,0.6]]' ]
  [ "$(jq -r '.diagnostics.metric.path' "$answer")" = reference ]
  [ "$(jq -r '.diagnostics.metric.reproduced' "$answer")" = true ]
  [ "$(jq -r '.diagnostics.inserted_vertices' "$answer")" = 0 ]
  [ "$(jq -r '.diagnostics.metric.distance_max' "$answer")" = 0 ]
  # "surface" is the default: no metric member in the diagnostics.
  post "$(body '"surface"')"
  expect 200
  [ "$(jq -r '.diagnostics.metric' "$answer")" = null ]
}

@test "a reference map with a flipped triangle comes back locally injective" {
  post "$(body '{"uv": [[0,0],[2,0],[2,2],[0,2],[2.6,1]]}')"
  expect 200
  [ "$(jq -r '.diagnostics.metric.reference_flipped' "$answer")" -ge 1 ]
  [ "$(jq -r '.diagnostics.flipped' "$answer")" = 0 ]
  [ "$(jq -r '.diagnostics.metric.path' "$answer")" != reference ]
  [ "$(jq -r '.diagnostics.metric.chart_size' "$answer")" = "$(jq -n '8 | sqrt')" ]
}

@test "bad metrics: 400 for the shape, 422 for the engine's refusals, each with its pointer" {
  post "$(body '{"uv": [[0,0],[2,0],[2,2]]}')"
  expect 422 metric_length_mismatch
  pointer_is /options/metric/uv
  [ "$(jq -r .title "$answer")" = "Invalid metric" ]
  post "$(body '{"uv": [[1,1],[1,1],[1,1],[1,1],[1,1]]}')"
  expect 422 metric_degenerate
  post "$(body '{"uv": [[0,0],[2,0],[2,2],[0,2],[1,1e999]]}')"
  expect 400 non_finite_number
  post "$(body '{"uv": 7}')"
  expect 400 wrong_type
  pointer_is /options/metric/uv
  post "$(body '{"uv": [[0,0],[2,0],[2],[0,2],[1,1]]}')"
  expect 400 wrong_length
  pointer_is /options/metric/uv/2
  post "$(body '"flat"')"
  expect 400 invalid_value
  pointer_is /options/metric
  post "$(body '[[0,0]]')"
  expect 400 wrong_type
  # Still serving.
  post "$(body '"surface"')"
  expect 200
}

@test "glTF: metric=texcoord:0 with boundary=texcoord:0 gives back a locally injective chart unchanged" {
  call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
    -F "model=@$FIX/swirl_blob.glb;type=model/gltf-binary" -F "boundary=<$FIX/swirl_blob_exp.json;type=application/json"
  expect 200
  cp "$answer" "$BATS_TEST_TMPDIR/chart.glb"
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0&metric=texcoord:0" -H 'Content-Type: model/gltf-binary' \
    --data-binary @"$BATS_TEST_TMPDIR/chart.glb"
  expect 200
  [ "$(jq -r '.diagnostics.metric.path' "$answer")" = reference ]
  [ "$(jq -r '.diagnostics.inserted_vertices' "$answer")" = 0 ]
  [ "$(jq -r '.diagnostics.metric.reference_flipped' "$answer")" = 0 ]
  # Bad specs and a missing set.
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0&metric=uv" -H 'Content-Type: model/gltf-binary' \
    --data-binary @"$BATS_TEST_TMPDIR/chart.glb"
  expect 400 gltf_invalid_request
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0&metric=texcoord:7" -H 'Content-Type: model/gltf-binary' \
    --data-binary @"$BATS_TEST_TMPDIR/chart.glb"
  expect 422 gltf_texcoord_missing
}
