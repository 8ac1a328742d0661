#!/usr/bin/env bats
# `lipmap map` with glTF in and out, the real binary. The test disk meshes (tests/data/meshes) are converted to .glb /
# .gltf at test time (tests/tools/gltf_fixture.js, into a temp dir) and mapped onto a circle and onto
# self-overlapping targets made by construction (a Tutte map followed by exp, certified by the fixture tool).
# Every glTF lipmap writes must pass Khronos's validator with zero errors (tests/tools/gltf_validate.js) and the
# checks of tests/tools/gltf_check_map.js (docs/contract.md on the float32 uv as stored, boundary exactly
# the float32 targets, NORMAL/COLOR_0/TEXCOORD_1 of inserted vertices interpolated). Bad glTF: exit 1 and one
# line naming what is wrong.
# Needs: node with the dev dependencies of package.json (npm ci), and a built binary ($LIPMAP_BIN or
# ${LIPMAP_BUILD_DIR:-build}/server/lipmap).

bats_require_minimum_version 1.5.0

setup_file() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  export ROOT
  export LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  export MESHES="$ROOT/tests/data/meshes"
  export TOOLS="$ROOT/tests/tools"
  export FIX="$BATS_FILE_TMPDIR"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP" >&2; return 1; }
  [ -d "$ROOT/node_modules/gltf-validator" ] || { echo "npm ci first (gltf-validator)" >&2; return 1; }
  local m
  for m in nefertiti.off swirl_blob.obj three_peaks.off blob.off; do
    node "$TOOLS/gltf_fixture.js" model "$MESHES/$m" "$FIX/${m%.*}.glb"
    node "$TOOLS/gltf_fixture.js" model "$MESHES/$m" "$FIX/${m%.*}.gltf"
    node "$TOOLS/gltf_fixture.js" target "$MESHES/$m" circle "$FIX/${m%.*}_circle.json"
  done
  node "$TOOLS/gltf_fixture.js" target "$MESHES/nefertiti.off" exp "$FIX/nefertiti_exp.json" 2>/dev/null
  node "$TOOLS/gltf_fixture.js" target "$MESHES/swirl_blob.obj" exp "$FIX/swirl_blob_exp.json" 2>/dev/null
}

lipmap() { run --separate-stderr "$LIPMAP" "$@"; }

# An error: exit code, nothing on stdout, exactly one line on stderr starting with the code.
expect_error() {
  [ "$status" -eq "$1" ] || { echo "status $status, wanted $1; stderr: $stderr" >&2; return 1; }
  [ -z "$output" ] || { echo "stdout not empty: $output" >&2; return 1; }
  [ "${#stderr_lines[@]}" -eq 1 ] || { echo "stderr has ${#stderr_lines[@]} lines: $stderr" >&2; return 1; }
  [[ "$stderr" == "lipmap: error: $2: "* ]] || { echo "stderr: $stderr (wanted code $2)" >&2; return 1; }
}

# map_and_check MESH TARGET IN_EXT OUT_EXT [extra lipmap args...]
map_and_check() {
  local mesh="$1" target="$2" in="$3" out="$4"; shift 4
  local result="$BATS_TEST_TMPDIR/${mesh}_${target}_${in}.$out"
  lipmap map "$FIX/$mesh.$in" --boundary "$FIX/${mesh}_$target.json" -o "$result" "$@"
  [ "$status" -eq 0 ] || { echo "lipmap map failed ($status): $stderr" >&2; return 1; }
  node "$TOOLS/gltf_check_map.js" "$result" "$FIX/$mesh.$in" "$FIX/${mesh}_$target.json"
  node "$TOOLS/gltf_validate.js" "$result"
}

@test "glb in, glb out: nefertiti onto a self-overlapping exp target" {
  map_and_check nefertiti exp glb glb
}

@test "gltf in, gltf out: nefertiti onto a self-overlapping exp target" {
  map_and_check nefertiti exp gltf gltf
}

@test "glb in, gltf out and gltf in, glb out: swirl_blob onto a self-overlapping exp target" {
  map_and_check swirl_blob exp glb gltf
  map_and_check swirl_blob exp gltf glb
}

@test "three_peaks and blob onto a circle, with --method tutte" {
  map_and_check three_peaks circle glb glb --method tutte
  map_and_check blob circle gltf gltf
}

@test "the output keeps the document: material, second mesh, image; diagnostics in the primitive's extras" {
  local out="$BATS_TEST_TMPDIR/n.gltf"
  lipmap map "$FIX/nefertiti.gltf" --boundary "$FIX/nefertiti_exp.json" -o "$out"
  [ "$status" -eq 0 ]
  jq -e '.materials[0].name == "fixture material" and .meshes[1].name == "untouched"
         and (.images | length) == 1 and .nodes[1].translation == [3, 0, 0]
         and .meshes[0].primitives[0].material == 0
         and .meshes[0].primitives[0].extras.lipmap.verdict == "self_overlapping"
         and .meshes[0].primitives[0].extras.lipmap.uv_convention == "TEXCOORD_0 = (u, 1 - v)"
         and (.meshes[0].primitives[0].extras.lipmap.diagnostics.timings_ms.total >= 0)
         and (.buffers | length) == 1 and (.buffers[0].uri | startswith("data:application/octet-stream;base64,"))' "$out"
}

@test "--boundary texcoord:N keeps the chart's outline exactly" {
  # A first map writes TEXCOORD_0; mapping that output again with texcoord:0 keeps its boundary bit for bit.
  local first="$BATS_TEST_TMPDIR/first.glb" second="$BATS_TEST_TMPDIR/second.glb"
  lipmap map "$FIX/swirl_blob.glb" --boundary "$FIX/swirl_blob_exp.json" -o "$first"
  [ "$status" -eq 0 ]
  lipmap map "$first" --boundary texcoord:0 -o "$second" --method tutte
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  node "$TOOLS/gltf_check_map.js" "$second" "$first" texcoord:0
  node "$TOOLS/gltf_validate.js" "$second"
  lipmap map "$first" --boundary texcoord:5 -o "$second"
  expect_error 1 gltf_texcoord_missing
  lipmap map "$MESHES/blob.off" --boundary texcoord:0 -o "$second"
  expect_error 2 usage
}

@test "seams: refused with the validate code and a hint, mapped with --weld position" {
  node "$TOOLS/gltf_fixture.js" model "$MESHES/nefertiti.off" "$BATS_TEST_TMPDIR/seam.glb" --split-seam
  local out="$BATS_TEST_TMPDIR/welded.glb"
  lipmap map "$BATS_TEST_TMPDIR/seam.glb" --boundary "$FIX/nefertiti_exp.json" -o "$out"
  [ "$status" -eq 1 ]
  [ "${#stderr_lines[@]}" -eq 1 ]
  [[ "$stderr" =~ ^lipmap:\ error:\ (not_connected|multiple_boundary_loops|non_manifold_vertex|not_a_disk):\ mesh\ 0\ primitive\ 0: ]]
  [[ "$stderr" == *"weld=position"* ]]
  lipmap map "$BATS_TEST_TMPDIR/seam.glb" --boundary "$FIX/nefertiti_exp.json" -o "$out" --weld position
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  node "$TOOLS/gltf_check_map.js" "$out" "$BATS_TEST_TMPDIR/seam.glb" "$FIX/nefertiti_exp.json" --weld
  node "$TOOLS/gltf_validate.js" "$out"
}

@test "non-indexed triangles: welded by position, written indexed" {
  node "$TOOLS/gltf_fixture.js" model "$MESHES/blob.off" "$BATS_TEST_TMPDIR/soup.gltf" --non-indexed
  # Welded, the soup's vertices are numbered in order of first use: its own target.
  node "$TOOLS/gltf_fixture.js" target "$BATS_TEST_TMPDIR/soup.gltf" circle "$BATS_TEST_TMPDIR/soup_circle.json" --weld
  local out="$BATS_TEST_TMPDIR/soup_out.gltf"
  lipmap map "$BATS_TEST_TMPDIR/soup.gltf" --boundary "$BATS_TEST_TMPDIR/soup_circle.json" -o "$out" --weld position
  [ "$status" -eq 0 ] || { echo "$stderr" >&2; return 1; }
  node "$TOOLS/gltf_check_map.js" "$out" "$BATS_TEST_TMPDIR/soup.gltf" "$BATS_TEST_TMPDIR/soup_circle.json" --weld
  node "$TOOLS/gltf_validate.js" "$out"
  jq -e '.meshes[0].primitives[0].indices != null' "$out"
}

@test "a mesh file or a JSON request mapped into a fresh glTF" {
  local out="$BATS_TEST_TMPDIR/fresh.glb"
  lipmap map "$MESHES/nefertiti.off" --boundary "$FIX/nefertiti_circle.json" -o "$out"
  [ "$status" -eq 0 ]
  node "$TOOLS/gltf_validate.js" "$out"
  local gltf_out="$BATS_TEST_TMPDIR/fresh.gltf"
  lipmap map "$MESHES/swirl_blob.obj" --boundary "$FIX/swirl_blob_exp.json" -o "$gltf_out"
  [ "$status" -eq 0 ]
  node "$TOOLS/gltf_validate.js" "$gltf_out"
}

@test "bad glTF: one line naming what is wrong, exit 1" {
  local kind code
  for kind in truncated:gltf_truncated magic:gltf_bad_magic buffer_range:gltf_buffer_out_of_range \
              accessor_type:gltf_accessor_mismatch no_triangles:gltf_no_triangles mode_lines:gltf_unsupported_mode \
              mode_strip:gltf_unsupported_mode; do
    code="${kind#*:}" kind="${kind%%:*}"
    node "$TOOLS/gltf_fixture.js" corrupt "$kind" "$FIX/blob.glb" "$BATS_TEST_TMPDIR/bad.glb"
    lipmap map "$BATS_TEST_TMPDIR/bad.glb" --boundary "$FIX/blob_circle.json" -o "$BATS_TEST_TMPDIR/x.glb"
    expect_error 1 "$code"
  done
  lipmap map "$BATS_TEST_TMPDIR/bad.glb" --boundary "$FIX/blob_circle.json" -o "$BATS_TEST_TMPDIR/x.glb"
  [[ "$stderr" == *TRIANGLE_STRIP* ]]
  node "$TOOLS/gltf_fixture.js" corrupt external_uri "$FIX/blob.gltf" "$BATS_TEST_TMPDIR/ext.gltf"
  lipmap map "$BATS_TEST_TMPDIR/ext.gltf" --boundary "$FIX/blob_circle.json" -o "$BATS_TEST_TMPDIR/x.glb"
  expect_error 1 gltf_external_uri
  lipmap map "$FIX/blob.glb" --boundary "$FIX/blob_circle.json" -o "$BATS_TEST_TMPDIR/x.glb" --gltf-mesh 4
  expect_error 1 gltf_mesh_not_found
  lipmap map "$FIX/blob.glb" --boundary "$FIX/blob_circle.json" -o "$BATS_TEST_TMPDIR/x.glb" --weld maybe
  expect_error 2 usage
  [ ! -e "$BATS_TEST_TMPDIR/x.glb" ]
}
