#!/usr/bin/env bats
# `lipmap classify`: the real binary on the polygons of tests/data/polygons, its exit codes, its one-line
# errors, and every answer validated against proto/classify-answer.schema.json.
# Needs: jq, node with the dev dependencies of package.json (scripts/test.sh installs them), and a built
# binary: $LIPMAP_BIN, or build/server/lipmap.

bats_require_minimum_version 1.5.0

setup() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  DATA="$ROOT/tests/data/polygons"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
}

# Runs lipmap with stdout and stderr apart: $output is the answer, $stderr the error line.
load helpers/cli.bash

# Runs lipmap on a body given as a string, through standard input.
lipmap_body() {
  local body="$1"; shift
  run --separate-stderr bash -c 'printf "%s" "$1" | "$2" classify - "${@:3}"' _ "$body" "$LIPMAP" "$@"
}

validates() {  # validates SCHEMA: $output against proto/SCHEMA
  printf '%s' "$output" | node "$ROOT/tests/tools/validate_json.js" "$1" -
}

# An error: the given exit code, nothing on stdout, exactly one line on stderr starting with the code.

# The triangulation of $output checked independently of the engine, for the polygon in file $1: n - 2
# triangles with indices in range, each polygon edge (i, i+1) the directed edge of exactly one triangle,
# each triangle of positive area (in floating point: these polygons are far from degenerate), one rotation
# index per vertex and the singular vertices exactly those with R_i > 0.
triangulation_is_valid() {
  jq -e -n --slurpfile body "$1" --argjson answer "$output" '
    ($body[0].polygon) as $p | ($p | length) as $n | $answer.triangulation as $t
    | ($t | length) == ($n - 2)
      and all($t[]; all(.[]; . >= 0 and . < $n))
      and ([range($n) as $i | [$t[] | [[.[0], .[1]], [.[1], .[2]], [.[2], .[0]]][] | select(. == [$i, (($i + 1) % $n)])] | length]
           | all(. == 1))
      and all($t[]; ($p[.[0]]) as $a | ($p[.[1]]) as $b | ($p[.[2]]) as $c
                    | (($b[0] - $a[0]) * ($c[1] - $a[1]) - ($b[1] - $a[1]) * ($c[0] - $a[0])) > 0)
      and ($answer.rotation_indices | length) == $n
      and ($answer.singular_vertices == [range($n) | select($answer.rotation_indices[.] > 0)])
      and ($answer.turning_number == 1 + ($answer.rotation_indices | add))' >/dev/null
}

# ---- verdicts -------------------------------------------------------------------------------------------

@test "square: simple, two triangles, schema-valid" {
  lipmap classify "$DATA/square.json"
  [ "$status" -eq 0 ]
  [ -z "$stderr" ]
  [ "$(jq -r .verdict <<<"$output")" = simple ]
  [ "$(jq -r .turning_number <<<"$output")" = 1 ]
  triangulation_is_valid "$DATA/square.json"
  validates classify-answer.schema.json
}

@test "clockwise square: not_self_overlapping with a reason, exit 0" {
  lipmap classify "$DATA/square_clockwise.json"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = not_self_overlapping ]
  [ "$(jq -r .turning_number <<<"$output")" = -1 ]
  [ "$(jq '.triangulation | length' <<<"$output")" = 0 ]
  [ -n "$(jq -r '.reason // empty' <<<"$output")" ]
  validates classify-answer.schema.json
}

@test "figure-eight: not_self_overlapping, turning number 0" {
  lipmap classify "$DATA/figure_eight.json"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = not_self_overlapping ]
  [ "$(jq -r .turning_number <<<"$output")" = 0 ]
  validates classify-answer.schema.json
}

@test "spiral strip wound 1.25 turns: self_overlapping, no singular vertex" {
  lipmap classify "$DATA/spiral_overlapping.json"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = self_overlapping ]
  [ "$(jq -c .singular_vertices <<<"$output")" = "[]" ]
  triangulation_is_valid "$DATA/spiral_overlapping.json"
  validates classify-answer.schema.json
}

@test "double turn: weakly_self_overlapping with one singular vertex" {
  lipmap classify "$DATA/double_turn.json"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = weakly_self_overlapping ]
  [ "$(jq -r .turning_number <<<"$output")" = 2 ]
  [ "$(jq '.singular_vertices | length' <<<"$output")" = 1 ]
  triangulation_is_valid "$DATA/double_turn.json"
  validates classify-answer.schema.json
}

@test "double turn with R_0 = 1 prescribed: vertex 0 is the singular one" {
  body="$(jq -c '.rotation_indices = ([1] + [range(.polygon | length - 1) | 0])' "$DATA/double_turn.json")"
  lipmap_body "$body"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = weakly_self_overlapping ]
  [ "$(jq -c .singular_vertices <<<"$output")" = "[0]" ]
  [ "$(jq -c '.rotation_indices[0]' <<<"$output")" = 1 ]
  validates classify-answer.schema.json
}

@test "double turn with all R_i = 0 prescribed: not_self_overlapping for that prescription, exit 0" {
  body="$(jq -c '.rotation_indices = [range(.polygon | length) | 0]' "$DATA/double_turn.json")"
  lipmap_body "$body"
  [ "$status" -eq 0 ]
  [ "$(jq -r .verdict <<<"$output")" = not_self_overlapping ]
  [ -n "$(jq -r '.reason // empty' <<<"$output")" ]
  validates classify-answer.schema.json
}

@test "every sample polygon: exit 0, one line of JSON, valid against the schema" {
  for f in "$DATA"/*.json; do
    lipmap classify "$f"
    [ "$status" -eq 0 ] || { echo "$f: status $status: $stderr" >&2; return 1; }
    [ "${#lines[@]}" -eq 1 ]
    validates classify-answer.schema.json || { echo "$f" >&2; return 1; }
  done
}

@test "the request files themselves are valid requests" {
  for f in "$DATA"/*.json; do
    node "$ROOT/tests/tools/validate_json.js" classify-request.schema.json "$f"
  done
}

@test "standard input (-) gives the same answer as the file, up to timings" {
  lipmap classify "$DATA/spiral_overlapping.json"
  from_file="$(jq -c 'del(.diagnostics.timings_ms)' <<<"$output")"
  run --separate-stderr bash -c '"$1" classify - < "$2"' _ "$LIPMAP" "$DATA/spiral_overlapping.json"
  [ "$status" -eq 0 ]
  [ "$(jq -c 'del(.diagnostics.timings_ms)' <<<"$output")" = "$from_file" ]
}

@test "--pretty: indented, same JSON, triangles one per line" {
  lipmap classify --pretty "$DATA/square.json"
  [ "$status" -eq 0 ]
  [ "${#lines[@]}" -gt 10 ]
  triangle_line=$'\n    \\[[0-9]+, [0-9]+, [0-9]+\\],\n'
  [[ "$output" =~ $triangle_line ]]
  pretty="$(jq -c 'del(.diagnostics.timings_ms)' <<<"$output")"
  lipmap classify "$DATA/square.json"
  [ "$(jq -c 'del(.diagnostics.timings_ms)' <<<"$output")" = "$pretty" ]
}

# ---- input errors: exit 1, one line on stderr -----------------------------------------------------------

@test "missing file: file_unreadable" {
  lipmap classify "$BATS_TEST_TMPDIR/nope.json"
  expect_error 1 file_unreadable
}

@test "a directory: file_unreadable" {
  lipmap classify "$DATA"
  expect_error 1 file_unreadable
}

@test "malformed JSON: invalid_json" {
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]'
  expect_error 1 invalid_json
}

@test "empty input: invalid_json" {
  lipmap_body ''
  expect_error 1 invalid_json
}

@test "binary garbage: invalid_json" {
  head -c 4096 /dev/urandom > "$BATS_TEST_TMPDIR/garbage"
  lipmap classify "$BATS_TEST_TMPDIR/garbage"
  expect_error 1 invalid_json
}

@test "body not an object: wrong_type" {
  lipmap_body '[[0,0],[1,0],[1,1]]'
  expect_error 1 wrong_type
}

@test "string coordinate: wrong_type with its JSON pointer" {
  lipmap_body '{"polygon": [[0,0],[1,"0"],[1,1]]}'
  expect_error 1 wrong_type
  [[ "$stderr" == *"/polygon/1/1: "* ]]
}

@test "point with three coordinates: wrong_length" {
  lipmap_body '{"polygon": [[0,0],[1,0,0],[1,1]]}'
  expect_error 1 wrong_length
  [[ "$stderr" == *"/polygon/1: "* ]]
}

@test "missing polygon: missing_field" {
  lipmap_body '{"rotation_indices": [0,0,0]}'
  expect_error 1 missing_field
}

@test "misspelt member: unknown_field" {
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]], "rotation_index": [0,0,0]}'
  expect_error 1 unknown_field
}

@test "fractional rotation index: not_an_integer" {
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0,0.5,0]}'
  expect_error 1 not_an_integer
  [[ "$stderr" == *"/rotation_indices/1: "* ]]
}

@test "coordinate that overflows a double: non_finite_number" {
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1e999]]}'
  expect_error 1 non_finite_number
  [[ "$stderr" == *"/polygon/2/1: "* ]]
}

@test "duplicate key: duplicate_key" {
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]], "polygon": [[0,0],[1,0],[1,1]]}'
  expect_error 1 duplicate_key
}

@test "absurd nesting: nesting_too_deep, no crash" {
  body="$(printf '[%.0s' $(seq 10000))"
  lipmap_body "$body"
  expect_error 1 nesting_too_deep
}

@test "engine errors: polygon_too_small, polygon_zero_length_edge, rotation_indices_length, rotation_index_out_of_range" {
  lipmap_body '{"polygon": [[0,0],[1,0]]}'
  expect_error 1 polygon_too_small
  lipmap_body '{"polygon": [[0,0],[1,0],[1,0],[0,1]]}'
  expect_error 1 polygon_zero_length_edge
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0]}'
  expect_error 1 rotation_indices_length
  lipmap_body '{"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0,99,0]}'
  expect_error 1 rotation_index_out_of_range
  [[ "$stderr" == *"/rotation_indices/1: "* ]]
}

@test "a newline inside a member name stays on one error line" {
  lipmap_body $'{"polygon": [[0,0],[1,0],[1,1]], "a\\nb": 1}'
  expect_error 1 unknown_field
}

# ---- usage: exit 2 ----------------------------------------------------------------------------------

@test "no subcommand: usage error" {
  lipmap
  expect_error 2 usage
}

@test "unknown subcommand: usage error naming it" {
  lipmap frobnicate
  expect_error 2 usage
  [[ "$stderr" == *frobnicate* ]]
}

@test "classify without FILE, with an unknown option, with two files: usage errors" {
  lipmap classify
  expect_error 2 usage
  lipmap classify --nope "$DATA/square.json"
  expect_error 2 usage
  lipmap classify "$DATA/square.json" "$DATA/square.json"
  expect_error 2 usage
}

@test "map without an output file is a usage error, exit 2 (map itself is tested in map.bats)" {
  lipmap map mesh.obj
  expect_error 2 usage
  [[ "$stderr" == *"--output is required"* ]]
}

@test "serve: a bad setting is a usage error, exit 2 (the service itself is tested in tests/http)" {
  lipmap serve --port 99999
  expect_error 2 usage
  lipmap serve --port 0 --deadline 0
  expect_error 2 usage
}

@test "--help: exit 0, lists the subcommands" {
  lipmap --help
  [ "$status" -eq 0 ]
  [[ "$output" == *classify* && "$output" == *map* && "$output" == *serve* ]]
  lipmap classify --help
  [ "$status" -eq 0 ]
  [[ "$output" == *--pretty* ]]
}

# ---- proto/ --------------------------------------------------------------------------------------------

@test "proto/: schemas compile, their examples validate, openapi.json's \$refs resolve" {
  run node "$ROOT/tests/tools/validate_json.js" --check
  [ "$status" -eq 0 ] || { echo "$output" >&2; return 1; }
}

@test "a wrong answer does not validate (the schema check has teeth)" {
  lipmap classify "$DATA/square.json"
  output="$(jq -c '.verdict = "probably" | .triangulation[0] = [0, 1]' <<<"$output")"
  if validates classify-answer.schema.json 2>/dev/null; then echo "a wrong answer validated" >&2; return 1; fi
}
