#!/usr/bin/env bats
# glTF through the HTTP service, the real `lipmap serve` on a free loopback port: the request forms
# (model/gltf-binary and model/gltf+json bodies with boundary=texcoord:N, multipart/form-data with parts model
# and boundary, the JSON envelope with gltf_base64), answers by Accept (model/gltf-binary, model/gltf+json, or
# the JSON answer), jobs, and bad glTF answered with a 4xx problem while the server keeps serving. Inputs are
# the test disk meshes converted at test time (tests/tools/gltf_fixture.js); every glTF answer passes
# Khronos's validator and tests/tools/gltf_check_map.js (docs/contract.md on the float32 uv as stored).

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() {
  require_tools
  [ -d "$HTTP_ROOT/node_modules/gltf-validator" ] || { echo "npm ci first (gltf-validator)" >&2; return 1; }
  export TOOLS="$HTTP_ROOT/tests/tools" MESHES="$HTTP_ROOT/tests/data/meshes" FIX="$BATS_FILE_TMPDIR"
  local m
  for m in nefertiti.off swirl_blob.obj blob.off; do
    node "$TOOLS/gltf_fixture.js" model "$MESHES/$m" "$FIX/${m%.*}.glb"
    node "$TOOLS/gltf_fixture.js" model "$MESHES/$m" "$FIX/${m%.*}.gltf"
    node "$TOOLS/gltf_fixture.js" target "$MESHES/$m" circle "$FIX/${m%.*}_circle.json"
  done
  node "$TOOLS/gltf_fixture.js" target "$MESHES/nefertiti.off" exp "$FIX/nefertiti_exp.json" 2>/dev/null
  node "$TOOLS/gltf_fixture.js" target "$MESHES/swirl_blob.obj" exp "$FIX/swirl_blob_exp.json" 2>/dev/null
  start_server MAIN --workers 2 --queue 16
}

teardown_file() {
  stop_server MAIN
}

# gltf_ok OUT IN BOUNDARY [--weld]: the answer file is a valid glTF and a correct map.
gltf_ok() {
  node "$TOOLS/gltf_validate.js" "$1"
  node "$TOOLS/gltf_check_map.js" "$@"
}

@test "multipart model + boundary, Accept model/gltf-binary: a self-overlapping map in the same document" {
  call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
    -F "model=@$FIX/nefertiti.glb;type=model/gltf-binary" -F "boundary=<$FIX/nefertiti_exp.json;type=application/json"
  expect 200
  [ "$ctype" = model/gltf-binary ]
  [ "$(head -c 4 "$answer")" = glTF ]
  cp "$answer" "$BATS_TEST_TMPDIR/out.glb"
  gltf_ok "$BATS_TEST_TMPDIR/out.glb" "$FIX/nefertiti.glb" "$FIX/nefertiti_exp.json"
}

@test "JSON envelope with gltf_base64, Accept model/gltf+json; and without Accept the JSON answer" {
  node -e 'const fs = require("fs"); process.stdout.write(JSON.stringify({gltf_base64: fs.readFileSync(process.argv[1]).toString("base64"),
    boundary: JSON.parse(fs.readFileSync(process.argv[2], "utf8")), options: {method: "tutte"}}))' \
    "$FIX/swirl_blob.gltf" "$FIX/swirl_blob_exp.json" >"$BATS_TEST_TMPDIR/envelope.json"
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' -H 'Accept: model/gltf+json' \
    --data-binary @"$BATS_TEST_TMPDIR/envelope.json"
  expect 200
  [ "$ctype" = model/gltf+json ]
  cp "$answer" "$BATS_TEST_TMPDIR/out.gltf"
  gltf_ok "$BATS_TEST_TMPDIR/out.gltf" "$FIX/swirl_blob.gltf" "$FIX/swirl_blob_exp.json"
  jq -e '.meshes[0].primitives[0].extras.lipmap.verdict == "self_overlapping" and .materials[0].name == "fixture material"' "$answer"
  call -s parametrize-answer.schema.json POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' \
    --data-binary @"$BATS_TEST_TMPDIR/envelope.json"
  expect 200
  [[ "$ctype" == application/json* ]]
  [ "$(jq -r .verdict "$answer")" = self_overlapping ]
}

@test "a bare model/gltf-binary body with boundary=texcoord:0 keeps the chart's outline" {
  # First a map whose TEXCOORD_0 is a self-overlapping chart, then that glb alone with boundary=texcoord:0.
  call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
    -F "model=@$FIX/swirl_blob.glb;type=model/gltf-binary" -F "boundary=<$FIX/swirl_blob_exp.json;type=application/json"
  expect 200
  cp "$answer" "$BATS_TEST_TMPDIR/chart.glb"
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0" -H 'Content-Type: model/gltf-binary' \
    -H 'Accept: model/gltf-binary' --data-binary @"$BATS_TEST_TMPDIR/chart.glb"
  expect 200
  cp "$answer" "$BATS_TEST_TMPDIR/again.glb"
  gltf_ok "$BATS_TEST_TMPDIR/again.glb" "$BATS_TEST_TMPDIR/chart.glb" texcoord:0
  # model/gltf+json works the same way, mesh/primitive given explicitly.
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0&mesh=0&primitive=0&weld=none" -H 'Content-Type: model/gltf+json' \
    -H 'Accept: model/gltf+json' --data-binary @"$FIX/blob.gltf"
  [ "$code" = 200 ] || [ "$code" = 422 ]  # the planar chart of blob's 4-vertex hole may or may not be usable
}

@test "seams: 422 with the validate code and a hint; weld=position maps them" {
  node "$TOOLS/gltf_fixture.js" model "$MESHES/nefertiti.off" "$BATS_TEST_TMPDIR/seam.glb" --split-seam
  call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
    -F "model=@$BATS_TEST_TMPDIR/seam.glb;type=model/gltf-binary" -F "boundary=<$FIX/nefertiti_exp.json"
  expect 422
  [[ "$(jq -r .code "$answer")" =~ ^(not_connected|multiple_boundary_loops|non_manifold_vertex|not_a_disk)$ ]]
  [[ "$(jq -r .detail "$answer")" == *weld=position* ]]
  call POST "$MAIN_URL/v1/parametrize?weld=position" -H 'Accept: model/gltf-binary' \
    -F "model=@$BATS_TEST_TMPDIR/seam.glb;type=model/gltf-binary" -F "boundary=<$FIX/nefertiti_exp.json"
  expect 200
  cp "$answer" "$BATS_TEST_TMPDIR/welded.glb"
  gltf_ok "$BATS_TEST_TMPDIR/welded.glb" "$BATS_TEST_TMPDIR/seam.glb" "$FIX/nefertiti_exp.json" --weld
}

@test "a JSON parametrize request answered in glTF (Accept), and a job's result in glTF" {
  node "$HELPERS/make_request.js" mesh "$MESHES/blob.off" circle >"$BATS_TEST_TMPDIR/blob.json"
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' -H 'Accept: model/gltf-binary' \
    --data-binary @"$BATS_TEST_TMPDIR/blob.json"
  expect 200
  [ "$ctype" = model/gltf-binary ]
  cp "$answer" "$BATS_TEST_TMPDIR/fresh.glb"
  node "$TOOLS/gltf_validate.js" "$BATS_TEST_TMPDIR/fresh.glb"
  # A glTF job: 202, then its result as JSON or as glTF in the submitted document.
  call -s job.schema.json POST "$MAIN_URL/v1/jobs" \
    -F "model=@$FIX/nefertiti.gltf;type=model/gltf+json" -F "boundary=<$FIX/nefertiti_exp.json"
  expect 202
  local id
  id="$(jq -r .id "$answer")"
  wait_for_job "$MAIN_URL" "$id" succeeded
  call -s parametrize-answer.schema.json GET "$MAIN_URL/v1/jobs/$id/result"
  expect 200
  call GET "$MAIN_URL/v1/jobs/$id/result" -H 'Accept: model/gltf+json'
  expect 200
  [ "$ctype" = model/gltf+json ]
  cp "$answer" "$BATS_TEST_TMPDIR/job.gltf"
  gltf_ok "$BATS_TEST_TMPDIR/job.gltf" "$FIX/nefertiti.gltf" "$FIX/nefertiti_exp.json"
}

@test "bad glTF: a 4xx problem naming what is wrong, and the server keeps serving" {
  local kind want
  for kind in truncated:400:gltf_truncated magic:400:gltf_bad_magic buffer_range:400:gltf_buffer_out_of_range \
              accessor_type:400:gltf_accessor_mismatch no_triangles:422:gltf_no_triangles \
              mode_lines:422:gltf_unsupported_mode mode_strip:422:gltf_unsupported_mode; do
    want="${kind#*:}" kind="${kind%%:*}"
    node "$TOOLS/gltf_fixture.js" corrupt "$kind" "$FIX/blob.glb" "$BATS_TEST_TMPDIR/bad.glb"
    call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
      -F "model=@$BATS_TEST_TMPDIR/bad.glb;type=model/gltf-binary" -F "boundary=<$FIX/blob_circle.json"
    expect "${want%%:*}" "${want#*:}"
    [ -n "$(jq -r .detail "$answer")" ]
  done
  [[ "$(jq -r .detail "$answer")" == *TRIANGLE_STRIP* ]]
  [ "$(jq -r .gltf_pointer "$answer")" = /meshes/0/primitives/0/mode ]
  node "$TOOLS/gltf_fixture.js" corrupt external_uri "$FIX/blob.gltf" "$BATS_TEST_TMPDIR/ext.gltf"
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0" -H 'Content-Type: model/gltf+json' --data-binary @"$BATS_TEST_TMPDIR/ext.gltf"
  expect 400 gltf_external_uri
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: model/gltf-binary' --data-binary @"$FIX/blob.glb"
  expect 400 gltf_invalid_request
  call POST "$MAIN_URL/v1/parametrize?boundary=texcoord:0&mesh=9" -H 'Content-Type: model/gltf-binary' --data-binary @"$FIX/blob.glb"
  expect 422 gltf_mesh_not_found
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: application/json' \
    --data-binary '{"gltf_base64": "not base64!", "boundary": "texcoord:0"}'
  expect 400 gltf_invalid_base64
  call POST "$MAIN_URL/v1/parametrize" -F "model=@$FIX/blob.glb;type=model/gltf-binary" -F 'boundary={"positions": [[0, "x"]]}'
  expect 400 wrong_type
  [ "$(jq -r .pointer "$answer")" = /boundary/positions/0/1 ]
  call POST "$MAIN_URL/v1/parametrize" -H 'Content-Type: text/csv' --data-binary 'a,b'
  expect 415 unsupported_media_type
  jq -e '.supported | index("model/gltf-binary")' "$answer"
  # Still serving: a good glTF request right after.
  call POST "$MAIN_URL/v1/parametrize" -H 'Accept: model/gltf-binary' \
    -F "model=@$FIX/blob.glb;type=model/gltf-binary" -F "boundary=<$FIX/blob_circle.json"
  expect 200
  call GET "$MAIN_URL/healthz"
  expect 200
}
