#!/usr/bin/env bats
# `lipmap map`: the real binary on small hand-written meshes and on a test mesh, its outputs (OBJ with vt,
# JSON answers validated against proto/parametrize-answer.schema.json, the SVG preview), --progress, and
# its exit codes and one-line errors.
# Needs: jq, node with the dev dependencies of package.json (scripts/test.sh installs them), and a built
# binary: $LIPMAP_BIN, or build/server/lipmap.

bats_require_minimum_version 1.5.0

setup() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  MESHES="$ROOT/tests/data/meshes"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
  T="$BATS_TEST_TMPDIR"
  # A square pyramid: boundary 0 1 2 3 (counterclockwise seen from above), apex 4.
  cat >"$T/pyramid.obj" <<'EOF'
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 0.5 0.25
f 1 2 5
f 2 3 5
f 3 4 5
f 4 1 5
EOF
  echo '{"positions": [[0, 0], [2, 0], [2, 2], [0, 2]]}' >"$T/square.json"
  # A fan: one raised interior vertex (0) and 8 boundary vertices on a circle.
  {
    echo "v 0 0 0.3"
    for k in 0 1 2 3 4 5 6 7; do
      awk -v k="$k" 'BEGIN { printf "v %.17g %.17g 0\n", cos(2 * 3.141592653589793 * k / 8), sin(2 * 3.141592653589793 * k / 8) }'
    done
    for k in 0 1 2 3 4 5 6 7; do echo "f 1 $((k + 2)) $(((k + 1) % 8 + 2))"; done
  } >"$T/fan.obj"
  # A U: simple, counterclockwise, empty kernel (no position of the fan's centre sees all 8 corners).
  echo '{"positions": [[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]]}' >"$T/u.json"
}

# Runs lipmap with stdout and stderr apart.
load helpers/cli.bash

validates() {  # validates SCHEMA FILE
  node "$ROOT/tests/tools/validate_json.js" "$1" "$2"
}

# An error: the given exit code, nothing on stdout, exactly one line on stderr starting with the code.

# ---- outputs ----------------------------------------------------------------------------------------------

@test "OBJ output: v, one vt per vertex, f v/vt; boundary vt equal to the prescribed positions" {
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.obj"
  [ "$status" -eq 0 ]
  [ -z "$stderr" ]
  [ -z "$output" ]
  [ "$(grep -c '^v ' "$T/out.obj")" -eq 5 ]
  [ "$(grep -c '^vt ' "$T/out.obj")" -eq 5 ]
  [ "$(grep -c '^f ' "$T/out.obj")" -eq 4 ]
  # Every face corner is a/a (vertex i uses vt i).
  grep '^f ' "$T/out.obj" | tr ' ' '\n' | grep '/' | awk -F/ '$1 != $2 { bad = 1 } END { exit bad }'
  # vt 1..4 are the square's corners, exactly; the apex lands inside.
  [ "$(grep '^vt ' "$T/out.obj" | head -4 | tr '\n' ';')" = "vt 0 0;vt 2 0;vt 2 2;vt 0 2;" ]
  # The original vertices keep their positions.
  [ "$(grep '^v ' "$T/out.obj" | head -1)" = "v 0 0 0" ]
}

@test "JSON output: the HTTP answer shape, schema-valid, consistent counts" {
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.json" --method tutte
  [ "$status" -eq 0 ]
  validates parametrize-answer.schema.json "$T/out.json"
  [ "$(jq -r .verdict "$T/out.json")" = simple ]
  [ "$(jq '.mesh.vertices | length' "$T/out.json")" -eq "$(jq '.uv | length' "$T/out.json")" ]
  [ "$(jq '.inserted | length' "$T/out.json")" -eq "$(jq .diagnostics.inserted_vertices "$T/out.json")" ]
  [ "$(jq .diagnostics.flipped "$T/out.json")" -eq 0 ]
  [ "$(jq -c '.uv[0:4]' "$T/out.json")" = '[[0,0],[2,0],[2,2],[0,2]]' ]
  [ "$(jq '.diagnostics.distortion.histogram.counts | add' "$T/out.json")" -eq "$(jq '.mesh.faces | length' "$T/out.json")" ]
  jq -e '.diagnostics.timings_ms | [.validate, .classify, .target_mesh, .intermediate_maps, .compose, .untangle, .refine, .optimize, .verify, .quality, .total] | all(. >= 0)' "$T/out.json" >/dev/null
}

@test "a whole parametrize request as MESH.json, without --boundary; --pretty" {
  jq -n --rawfile obj "$T/pyramid.obj" '{
      mesh: {vertices: [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0.5,0.5,0.25]], faces: [[0,1,4],[1,2,4],[2,3,4],[3,0,4]]},
      boundary: {vertices: [2, 3, 0, 1], positions: [[2,2],[0,2],[0,0],[2,0]]},
      options: {method: "harmonic", refine: true}}' >"$T/request.json"
  lipmap map "$T/request.json" -o "$T/out.json" --pretty
  [ "$status" -eq 0 ]
  [ "$(wc -l <"$T/out.json")" -gt 10 ]
  validates parametrize-answer.schema.json "$T/out.json"
  [ "$(jq -c .boundary_loop "$T/out.json")" = '[2,3,0,1]' ]
  [ "$(jq -c '.uv[2]' "$T/out.json")" = '[2,2]' ]
}

@test "--boundary replaces the request's boundary" {
  jq -n '{mesh: {vertices: [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0.5,0.5,0.25]], faces: [[0,1,4],[1,2,4],[2,3,4],[3,0,4]]},
          boundary: {positions: [[0,0],[1,0],[1,1],[0,1]]}}' >"$T/request.json"
  lipmap map "$T/request.json" --boundary "$T/square.json" -o "$T/out.json"
  [ "$status" -eq 0 ]
  [ "$(jq -c '.uv[2]' "$T/out.json")" = '[2,2]' ]
}

@test "a fan onto a polygon with an empty kernel: refined, inserted vertices reported, SVG preview" {
  lipmap map "$T/fan.obj" --boundary "$T/u.json" -o "$T/out.json" --preview "$T/out.svg"
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  validates parametrize-answer.schema.json "$T/out.json"
  [ "$(jq '.inserted | length' "$T/out.json")" -gt 0 ]
  [ "$(jq .diagnostics.flipped_before_refinement "$T/out.json")" -gt 0 ]
  [ "$(jq .diagnostics.flipped "$T/out.json")" -eq 0 ]
  head -1 "$T/out.svg" | grep -q '^<?xml version="1.0"'
  grep -q '<svg xmlns="http://www.w3.org/2000/svg" version="1.1"' "$T/out.svg"
  # One polygon per triangle, plus the outline; one marker per inserted vertex.
  local faces polygons
  faces="$(jq '.mesh.faces | length' "$T/out.json")"
  polygons="$(grep -c '<polygon' "$T/out.svg")"
  [ "$polygons" -eq $((faces + 1)) ]
  [ "$(sed -n '/<g id="inserted"/,/<\/g>/p' "$T/out.svg" | grep -c '<circle')" -eq "$(jq '.inserted | length' "$T/out.json")" ]
  ! grep -q 'class="flipped"' "$T/out.svg"
}

@test "--no-refine: the vertex-wise map, flips counted, drawn in red" {
  lipmap map "$T/fan.obj" --boundary "$T/u.json" -o "$T/out.json" --no-refine --preview "$T/out.svg"
  [ "$status" -eq 0 ]
  validates parametrize-answer.schema.json "$T/out.json"
  [ "$(jq '.inserted | length' "$T/out.json")" -eq 0 ]
  [ "$(jq .diagnostics.flipped "$T/out.json")" -gt 0 ]
  grep -q 'class="flipped" fill="#e31a1c"' "$T/out.svg"
}

@test "--progress: one line per stage start and end, then a summary, on stderr" {
  # A non-convex boundary (a dart, reflex at its third corner): every stage of the paper's path.
  echo '{"positions": [[0, 0], [2, 0], [1, 0.8], [0, 2]]}' >"$T/dart.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/dart.json" -o "$T/out.obj" --progress
  [ "$status" -eq 0 ]
  [ -z "$output" ]
  for stage in validate classify target_mesh intermediate_maps compose untangle refine optimize verify quality; do
    grep -q "^lipmap: progress: $stage \.\.\.$" <<<"$stderr"
    grep -q "^lipmap: progress: $stage done in " <<<"$stderr"
  done
  grep -q '^lipmap: done: verdict simple, ' <<<"$stderr"
  # A strictly convex one (the square): the direct map onto it, no target mesh and no composition.
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.obj" --progress
  [ "$status" -eq 0 ]
  for stage in validate classify intermediate_maps optimize verify quality; do
    grep -q "^lipmap: progress: $stage done in " <<<"$stderr"
  done
  [ "$(grep -c -e "^lipmap: progress: target_mesh" -e "^lipmap: progress: compose" <<<"$stderr")" -eq 0 ]
  grep -q '^lipmap: done: verdict simple, 5 vertices (0 inserted), 4 triangles' <<<"$stderr"
}

@test "a test mesh (nefertiti) onto a circle, both methods" {
  # 34 boundary vertices on the unit circle.
  jq -n '{positions: [range(34) | [((. * 2 * 3.141592653589793 / 34) | cos), ((. * 2 * 3.141592653589793 / 34) | sin)]]}' >"$T/circle.json"
  for method in harmonic tutte; do
    lipmap map "$MESHES/nefertiti.off" --boundary "$T/circle.json" -o "$T/out.json" --method "$method" --target-density 0.5
    [ "$status" -eq 0 ] || { echo "$method: $stderr" >&2; return 1; }
    validates parametrize-answer.schema.json "$T/out.json"
    [ "$(jq -r .verdict "$T/out.json")" = simple ]
    [ "$(jq .diagnostics.flipped "$T/out.json")" -eq 0 ]
  done
}

@test "--method extremal: nefertiti onto a C shape, schema-valid, diagnostics.extremal, no optimize stage" {
  # 34 boundary vertices on a thick C (an annular sector of 300 degrees): 17 outer, 17 inner.
  jq -n '[range(17) | (. / 16 * 5 * 3.141592653589793 / 3 + 0.5236) | [2 * cos, 2 * sin]]
         + [range(17) | ((16 - .) / 16 * 5 * 3.141592653589793 / 3 + 0.5236) | [cos, sin]] | {positions: .}' >"$T/c.json"
  lipmap map "$MESHES/nefertiti.off" --boundary "$T/c.json" -o "$T/out.json" --method extremal
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  validates parametrize-answer.schema.json "$T/out.json"
  [ "$(jq .diagnostics.flipped "$T/out.json")" -eq 0 ]
  jq -e '.diagnostics.extremal | .iterations >= 1 and .k >= 0 and .k < 1' "$T/out.json" >/dev/null
  [ "$(jq .diagnostics.optimization.ran "$T/out.json")" = false ]
}

# ---- errors ---------------------------------------------------------------------------------------------

@test "clockwise boundary: not_self_overlapping, exit 1, names the verdict" {
  echo '{"positions": [[0, 0], [0, 2], [2, 2], [2, 0]]}' >"$T/cw.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/cw.json" -o "$T/out.obj"
  expect_error 1 not_self_overlapping
  [[ "$stderr" == *"verdict: not_self_overlapping"* ]]
  [ ! -e "$T/out.obj" ]
}

@test "figure eight: not_self_overlapping, turning number 0" {
  echo '{"positions": [[0, 0], [1, -1], [2, 0], [3, 1], [4, 0], [3, -1], [2, 0.01], [1, 1]]}' >"$T/eight8.json"
  lipmap map "$T/fan.obj" --boundary "$T/eight8.json" -o "$T/out.obj"
  expect_error 1 not_self_overlapping
  [[ "$stderr" == *"turning number 0"* ]]
}

@test "usage errors: no --boundary for a mesh file, bad -o extension, unknown method, non-positive density" {
  lipmap map "$T/pyramid.obj" -o "$T/out.obj"
  expect_error 2 usage
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.txt"
  expect_error 2 usage
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.obj" --method lscm
  expect_error 2 usage
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/out.obj" --target-density 0
  expect_error 2 usage
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json"
  expect_error 2 usage
}

@test "input errors: missing mesh, bad boundary JSON (with its pointer), wrong boundary length" {
  lipmap map "$T/nope.obj" --boundary "$T/square.json" -o "$T/out.obj"
  expect_error 1 mesh_file_unreadable
  echo '{"positions": [[0, 0], [2, "0"], [2, 2], [0, 2]]}' >"$T/bad.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/bad.json" -o "$T/out.obj"
  expect_error 1 wrong_type
  [[ "$stderr" == *"bad.json: /positions/1/1: "* ]]
  echo '{"positions": [[0, 0], [2, 0], [2, 2]]}' >"$T/short.json"
  lipmap map "$T/pyramid.obj" --boundary "$T/short.json" -o "$T/out.obj"
  expect_error 1 boundary_length_mismatch
  lipmap map "$T/pyramid.obj" --boundary "$T/missing.json" -o "$T/out.obj"
  expect_error 1 file_unreadable
}

@test "a degenerate mesh is refused with degenerate_face" {
  # Face (0, 2, 1) is collinear: 0.5 lies between 0 and 1 on the x axis.
  printf 'v 0 0 0\nv 1 0 0\nv 0.5 0 0\nv 0 1 0\nf 1 2 4\nf 1 3 2\n' >"$T/flat2.obj"
  lipmap map "$T/flat2.obj" --boundary "$T/square.json" -o "$T/out.obj"
  expect_error 1 degenerate_face
}

@test "an unwritable output is an input error" {
  lipmap map "$T/pyramid.obj" --boundary "$T/square.json" -o "$T/no/such/dir/out.obj"
  expect_error 1 output_file_unwritable
}

@test "--optimize none / mips, --max-iterations, --no-untangle: options reach the engine and its diagnostics" {
  lipmap map "$T/fan.obj" --boundary "$T/u.json" -o "$T/none.json" --optimize none
  [ "$status" -eq 0 ]
  validates parametrize-answer.schema.json "$T/none.json"
  [ "$(jq -r .diagnostics.optimization.ran "$T/none.json")" = false ]
  lipmap map "$T/fan.obj" --boundary "$T/u.json" -o "$T/mips.json" --optimize mips --max-iterations 50 --no-untangle
  [ "$status" -eq 0 ]
  validates parametrize-answer.schema.json "$T/mips.json"
  [ "$(jq -r .diagnostics.optimization.energy "$T/mips.json")" = mips ]
  [ "$(jq -r .diagnostics.untangling.attempted "$T/mips.json")" = false ]
  [ "$(jq '.diagnostics.optimization.iterations <= 50' "$T/mips.json")" = true ]
  lipmap map "$T/fan.obj" --boundary "$T/u.json" -o "$T/bad.json" --optimize fast
  [ "$status" -eq 2 ]
}
