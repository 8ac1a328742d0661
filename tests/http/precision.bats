#!/usr/bin/env bats
# Double precision through POST /v1/parametrize: every original vertex of the answer keeps its 3D position
# bit for bit. The body's coordinates are ones a float cannot hold; request and answer are parsed by node's
# JSON.parse (correctly rounded, independent of the program) and compared with Object.is.

bats_require_minimum_version 1.5.0
load helpers/server

setup_file() { serve_for_file PRECISION --workers 1; }

teardown_file() { stop_server PRECISION; }

# body NAME SHAPE SCALE OFFSET: a grid body (make_request.js) with every coordinate c -> c * SCALE + OFFSET.
body() {
  local f="$BATS_TEST_TMPDIR/$1.json"
  node "$HELPERS/make_request.js" grid 6 "$2" | node -e '
    const b = JSON.parse(require("fs").readFileSync(0, "utf8"));
    const s = Number(process.argv[1]), o = Number(process.argv[2]);
    b.mesh.vertices = b.mesh.vertices.map((p) => p.map((c, k) => c * s + o * (k + 1)));
    process.stdout.write(JSON.stringify(b));' "$3" "$4" >"$f"
  echo "$f"
}

# kept_bit_for_bit REQUEST: the last answer's first n vertices are the request's n vertices, bit for bit.
kept_bit_for_bit() {
  node -e '
    const fs = require("fs");
    const request = JSON.parse(fs.readFileSync(process.argv[1], "utf8")).mesh.vertices;
    const answer = JSON.parse(fs.readFileSync(process.argv[2], "utf8")).mesh.vertices;
    let notFloat = 0;
    request.forEach((p, i) => p.forEach((c, k) => {
      if (Math.fround(c) !== c) notFloat++;
      if (!Object.is(c, answer[i][k])) throw new Error(`vertex ${i} coordinate ${k}: sent ${c}, answered ${answer[i][k]}`);
    }));
    if (notFloat === 0) throw new Error("every coordinate sent is a float: the test proves nothing");
  ' "$1" "$answer"
}

@test "POST /v1/parametrize keeps every original vertex bit for bit (simple and self-overlapping targets)" {
  local shape scale offset f n=0
  for shape in square spiral; do
    for scale in 1 0.1234567890123456789 98765.43210987654; do
      for offset in 0 1000.0000000000002 -3.3333333333333335e-7; do
        n=$((n + 1))
        f="$(body "request$n" "$shape" "$scale" "$offset")"
        call -s parametrize-answer.schema.json POST "$PRECISION_URL/v1/parametrize" \
          -H 'Content-Type: application/json' --data-binary "@$f"
        expect 200
        check_map "$f"
        kept_bit_for_bit "$f"
      done
    done
  done
}
