#!/usr/bin/env bats
# Double precision end to end: `lipmap map` keeps every original vertex's 3D position bit for bit, from an
# OBJ or OFF file to an OBJ answer, and from a JSON body to a JSON answer. The inputs hold coordinates that
# a float cannot hold; the check parses input and output independently of the program (node's Number and
# JSON.parse, both correctly rounded) and compares with Object.is.
# Needs: node, and a built binary: $LIPMAP_BIN, or build/server/lipmap.

bats_require_minimum_version 1.5.0

setup() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
  T="$BATS_TEST_TMPDIR"
  # A 7 x 7 grid whose boundary winds 1.25 turns (self-overlapping: the map needs refinement), moved so
  # that every coordinate has all 17 digits: x / 3 + 1000.1 and so on.
  node "$ROOT/tests/http/helpers/make_request.js" grid 7 spiral | node -e '
    const body = JSON.parse(require("fs").readFileSync(0, "utf8"));
    body.mesh.vertices = body.mesh.vertices.map(([x, y, z]) => [x / 3 + 1000.1, y * Math.PI - 0.7, z * Math.E + 1e-3]);
    process.stdout.write(JSON.stringify(body));' >"$T/body.json"
  node -e '
    const fs = require("fs"), body = JSON.parse(fs.readFileSync(process.argv[1], "utf8"));
    // String(x) is the shortest text that reads back to x.
    const v = body.mesh.vertices.map((p) => "v " + p.map(String).join(" "));
    fs.writeFileSync(process.argv[2], "# precision test\r\n" + v.join("\r\n") + "\r\n" +
      body.mesh.faces.map((f) => "f " + f.map((i) => i + 1).join(" ")).join("\r\n") + "\r\n");
    fs.writeFileSync(process.argv[3], "OFF\n" + body.mesh.vertices.length + " " + body.mesh.faces.length + " 0\n" +
      body.mesh.vertices.map((p) => p.map(String).join(" ")).join("\n") + "\n" +
      body.mesh.faces.map((f) => "3 " + f.join(" ")).join("\n") + "\n");
    fs.writeFileSync(process.argv[4], JSON.stringify({positions: body.boundary.positions}));
  ' "$T/body.json" "$T/in.obj" "$T/in.off" "$T/boundary.json"
}

# vertices FILE: the 3D positions of an OBJ (v lines), OFF or JSON (mesh.vertices) file as JSON, parsed by node.
# same_originals ORIGINAL ANSWER: ANSWER's first n vertices are ORIGINAL's n vertices, bit for bit; at least
# one coordinate is not a float (else the test would prove nothing), and the answer has inserted vertices
# beyond them when it says so.
same_originals() {
  node -e '
    const fs = require("fs");
    function vertices(file) {
      const text = fs.readFileSync(file, "utf8");
      if (file.endsWith(".json")) return JSON.parse(text).mesh.vertices;
      const lines = text.split(/\r?\n/).map((l) => l.trim().split(/\s+/));
      if (file.endsWith(".off")) {
        const n = Number(lines[1][0]);
        return lines.slice(2, 2 + n).map((t) => t.map(Number));
      }
      return lines.filter((t) => t[0] === "v").map((t) => t.slice(1).map(Number));
    }
    const original = vertices(process.argv[1]), answer = vertices(process.argv[2]);
    if (answer.length < original.length) throw new Error(`answer has ${answer.length} vertices, input ${original.length}`);
    let notFloat = 0;
    original.forEach((p, i) => p.forEach((c, k) => {
      if (Math.fround(c) !== c) notFloat++;
      if (!Object.is(c, answer[i][k]))
        throw new Error(`vertex ${i} coordinate ${k}: input ${c}, answer ${answer[i][k]}`);
    }));
    if (notFloat === 0) throw new Error("every input coordinate is a float: the test proves nothing");
    console.log(`${original.length} vertices kept bit for bit (${notFloat} coordinates a float cannot hold), ` +
                `${answer.length - original.length} inserted`);
  ' "$1" "$2"
}

@test "OBJ in, OBJ out: every original vertex keeps its position bit for bit" {
  run "$LIPMAP" map "$T/in.obj" --boundary "$T/boundary.json" -o "$T/out.obj"
  [ "$status" -eq 0 ] || { echo "$output" >&2; return 1; }
  same_originals "$T/in.obj" "$T/out.obj"
  same_originals "$T/body.json" "$T/out.obj"
}

@test "OFF in, OBJ out: every original vertex keeps its position bit for bit" {
  run "$LIPMAP" map "$T/in.off" --boundary "$T/boundary.json" -o "$T/out.obj"
  [ "$status" -eq 0 ] || { echo "$output" >&2; return 1; }
  same_originals "$T/in.off" "$T/out.obj"
}

@test "JSON body in, JSON answer out: every original vertex keeps its position bit for bit" {
  # Untangling off: the spiral then needs refinement, so inserted vertices follow the originals (with
  # untangling on, this mesh maps with none inserted, and the point of the test would be lost).
  run "$LIPMAP" map "$T/body.json" --no-untangle -o "$T/out.json"
  [ "$status" -eq 0 ] || { echo "$output" >&2; return 1; }
  same_originals "$T/body.json" "$T/out.json"
  [ "$(node -e 'const a = JSON.parse(require("fs").readFileSync(process.argv[1])); console.log(a.inserted.length)' "$T/out.json")" -gt 0 ]
}

@test "the file and JSON routes give the same original positions" {
  run "$LIPMAP" map "$T/in.obj" --boundary "$T/boundary.json" -o "$T/obj.json"
  [ "$status" -eq 0 ] || { echo "$output" >&2; return 1; }
  same_originals "$T/body.json" "$T/obj.json"
}
