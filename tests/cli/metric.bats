#!/usr/bin/env bats
# `lipmap map --metric` (paper 5.2, variable metric), the real binary: a reference map from a JSON file or a
# glTF TEXCOORD set, the reproduction of a locally injective one, the repair of a flipped one, and bad metrics
# answered with one line and exit 1 (2 for usage).
# Needs: jq, node with the dev dependencies of package.json, and a built binary ($LIPMAP_BIN or
# ${LIPMAP_BUILD_DIR:-build}/server/lipmap).

bats_require_minimum_version 1.5.0

setup() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  MESHES="$ROOT/tests/data/meshes"
  TOOLS="$ROOT/tests/tools"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
  T="$BATS_TEST_TMPDIR"
  cat >"$T/pyramid.obj" <<'OBJ'
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 0.5 0.25
f 1 2 5
f 2 3 5
f 3 4 5
f 4 1 5
OBJ
  echo '{"positions": [[0, 0], [2, 0], [2, 2], [0, 2]]}' >"$T/square.json"
}

load helpers/cli.bash

@test "--metric FILE: a locally injective reference comes back unchanged; a flipped one without flips" {
  echo '{"uv": [[0, 0], [2, 0], [2, 2], [0, 2], [0.7, 1.4]]}' >"$T/metric.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/metric.json" -o "$T/out.json"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  [ "$(jq -c .uv "$T/out.json")" = '[[0,0],[2,0],[2,2],[0,2],[0.7,1.4]]' ]
  [ "$(jq -r .diagnostics.metric.path "$T/out.json")" = reference ]
  node "$TOOLS/validate_json.js" parametrize-answer.schema.json "$T/out.json"
  echo '{"uv": [[0, 0], [2, 0], [2, 2], [0, 2], [-0.5, 1]]}' >"$T/flipped.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/flipped.json" -o "$T/out.json"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  [ "$(jq -r .diagnostics.metric.reference_flipped "$T/out.json")" -ge 1 ]
  [ "$(jq -r .diagnostics.flipped "$T/out.json")" = 0 ]
  # --metric surface replaces a request's own metric.
  jq -n --slurpfile m "$T/metric.json" '{mesh: {vertices: [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0.5,0.5,0.25]], faces: [[0,1,4],[1,2,4],[2,3,4],[3,0,4]]}, boundary: {positions: [[0,0],[2,0],[2,2],[0,2]]}, options: {metric: $m[0]}}' >"$T/req.json"
  lipmap map "$T/req.json" --metric surface -o "$T/out.json"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  [ "$(jq -r .diagnostics.metric "$T/out.json")" = null ]
}

@test "bad metrics: one line, exit 1; texcoord without glTF: usage" {
  echo '{"uv": [[0, 0], [2, 0], [2, 2]]}' >"$T/short.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/short.json" -o "$T/out.json"
  expect_error 1 metric_length_mismatch
  [[ "$stderr" == *"short.json: /uv: "* ]]
  echo '{"uv": [[3, 3], [3, 3], [3, 3], [3, 3], [3, 3]]}' >"$T/zero.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/zero.json" -o "$T/out.json"
  expect_error 1 metric_degenerate
  echo '{"uv": [[0, 0], [2, 0], [2, 2], [0, 2], [1, 1e999]]}' >"$T/inf.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/inf.json" -o "$T/out.json"
  expect_error 1 non_finite_number
  echo '{"uv": "no"}' >"$T/type.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/type.json" -o "$T/out.json"
  expect_error 1 wrong_type
  [[ "$stderr" == *"type.json: /uv: "* ]]
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric "$T/missing.json" -o "$T/out.json"
  expect_error 1 file_unreadable
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" --metric texcoord:0 -o "$T/out.json"
  expect_error 2 usage
  [ ! -e "$T/out.json" ]
}

@test "--metric texcoord:0 with --boundary texcoord:0 on glTF: the chart comes back unchanged" {
  [ -d "$ROOT/node_modules/gltf-validator" ] || skip "npm ci first (gltf-validator)"
  node "$TOOLS/gltf_fixture.js" model "$MESHES/swirl_blob.obj" "$T/swirl.glb"
  node "$TOOLS/gltf_fixture.js" target "$MESHES/swirl_blob.obj" exp "$T/exp.json" 2>/dev/null
  lipmap map "$T/swirl.glb" --boundary "$T/exp.json" -o "$T/chart.glb"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  lipmap map "$T/chart.glb" --boundary texcoord:0 --metric texcoord:0 -o "$T/again.json"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  [ "$(jq -r .diagnostics.metric.path "$T/again.json")" = reference ]
  [ "$(jq -r .diagnostics.inserted_vertices "$T/again.json")" = 0 ]
  lipmap map "$T/chart.glb" --boundary texcoord:0 --metric texcoord:3 -o "$T/again.json"
  expect_error 1 gltf_texcoord_missing
}
