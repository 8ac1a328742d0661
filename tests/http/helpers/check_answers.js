#!/usr/bin/env node
// Checks the answers the HTTP tests collected, in one Node process (starting ajv once per answer would
// cost half a second each). Test-only; never shipped.
//
//   node check_answers.js MANIFEST
// MANIFEST has one check per line:
//   schema NAME FILE       FILE validates against proto/NAME (ajv 2020-12, strict, formats), loaded exactly as
//                          tests/tools/validate_json.js loads them
//   map REQUEST ANSWER     ANSWER (a parametrize answer) passes the checks of docs/contract.md for REQUEST
//   metrics FILE           FILE is Prometheus text format with the service's metric families
// Prints one line per failure and exits 1 when any check fails; prints "check_answers: N checks passed".
"use strict";

const fs = require("fs");
const path = require("path");
const Ajv2020 = require("ajv/dist/2020").default;
const addFormats = require("ajv-formats").default;
const { boundaryLoop } = require("./make_request.js");

const protoDir = path.resolve(__dirname, "..", "..", "..", "proto");

function loadAjv() {
  const ajv = new Ajv2020({ strict: true, allErrors: true });
  addFormats(ajv);
  for (const name of fs.readdirSync(protoDir).filter((n) => n.endsWith(".schema.json")).sort())
    ajv.addSchema(JSON.parse(fs.readFileSync(path.join(protoDir, name), "utf8")), name);
  return ajv;
}

// ---- exact orientation on doubles ----------------------------------------------------------------------

// x = m * 2^e exactly, m a BigInt.
function decompose(x) {
  if (x === 0) return { m: 0n, e: 0 };
  const view = new DataView(new ArrayBuffer(8));
  view.setFloat64(0, x);
  const hi = view.getUint32(0), lo = view.getUint32(4);
  const sign = hi >>> 31 ? -1n : 1n;
  const biased = (hi >>> 20) & 0x7ff;
  let mantissa = (BigInt(hi & 0xfffff) << 32n) | BigInt(lo);
  let e;
  if (biased === 0) e = -1074; // subnormal
  else {
    mantissa |= 1n << 52n;
    e = biased - 1075;
  }
  return { m: sign * mantissa, e };
}

function exactOrientSign(a, b, c) {
  const parts = [a[0], a[1], b[0], b[1], c[0], c[1]].map(decompose);
  const E = Math.min(...parts.map((p) => p.e));
  const [ax, ay, bx, by, cx, cy] = parts.map((p) => p.m << BigInt(p.e - E));
  const det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
  return det > 0n ? 1 : det < 0n ? -1 : 0;
}

const EPS = Math.pow(2, -53);
const ERRBOUND = (3 + 16 * EPS) * EPS; // Shewchuk's ccwerrboundA

function orientSign(a, b, c) {
  const l = (a[0] - c[0]) * (b[1] - c[1]);
  const r = (a[1] - c[1]) * (b[0] - c[0]);
  const det = l - r;
  const bound = ERRBOUND * (Math.abs(l) + Math.abs(r));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  return exactOrientSign(a, b, c);
}

// ---- docs/contract.md ------------------------------------------------------------------------------

function triangleArea3(p, q, r) {
  const u = [q[0] - p[0], q[1] - p[1], q[2] - p[2]], v = [r[0] - p[0], r[1] - p[1], r[2] - p[2]];
  const c = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
  return 0.5 * Math.hypot(c[0], c[1], c[2]);
}

function checkMap(request, answer) {
  const errors = [];
  const fail = (m) => { if (errors.length < 20) errors.push(m); };
  const V = request.mesh.vertices, F = request.mesh.faces;
  const n = V.length;
  const mv = answer.mesh.vertices, mf = answer.mesh.faces, uv = answer.uv, ins = answer.inserted;
  if (uv.length !== mv.length) fail(`uv has ${uv.length} entries for ${mv.length} vertices`);
  if (mv.length !== n + ins.length) fail(`${mv.length} vertices != ${n} original + ${ins.length} inserted`);
  if (answer.diagnostics.inserted_vertices !== ins.length) fail("diagnostics.inserted_vertices != inserted.length");
  if (answer.diagnostics.flipped !== 0) fail(`diagnostics.flipped = ${answer.diagnostics.flipped}`);
  for (const f of mf) for (const i of f) if (!(Number.isInteger(i) && i >= 0 && i < mv.length)) { fail(`face index ${i} out of range`); return errors; }

  // 1. original vertices keep index and exact position; inserted ones lie on an original edge at a + t (b - a)
  for (let i = 0; i < n; i++)
    if (mv[i][0] !== V[i][0] || mv[i][1] !== V[i][1] || mv[i][2] !== V[i][2]) fail(`vertex ${i} moved: ${mv[i]} != ${V[i]}`);
  const edges = new Set();
  for (const f of F) for (let c = 0; c < 3; c++) {
    const a = f[c], b = f[(c + 1) % 3];
    edges.add(Math.min(a, b) + "," + Math.max(a, b));
  }
  ins.forEach((iv, j) => {
    const [a, b] = iv.edge, t = iv.t;
    if (!(a < b)) fail(`inserted ${j}: edge (${a}, ${b}) not ordered`);
    if (!edges.has(a + "," + b)) fail(`inserted ${j}: (${a}, ${b}) is not an edge of the input mesh`);
    if (!(t > 0 && t < 1)) fail(`inserted ${j}: t = ${t} not in (0, 1)`);
    const p = mv[n + j];
    if (!p || !V[a] || !V[b]) return;
    for (let k = 0; k < 3; k++) {
      const want = V[a][k] + t * (V[b][k] - V[a][k]);
      const scale = 1 + Math.abs(V[a][k]) + Math.abs(V[b][k]);
      if (Math.abs(p[k] - want) > 1e-9 * scale) fail(`inserted ${j}: position ${p} is not a + t (b - a)`);
    }
  });

  // topology of the refined mesh: each directed edge once, one boundary loop, Euler characteristic 1
  const directed = new Map();
  for (const f of mf) for (let c = 0; c < 3; c++) {
    const key = f[c] + "," + f[(c + 1) % 3];
    if (directed.has(key)) fail(`directed edge ${key} used twice (non-manifold or inconsistent orientation)`);
    directed.set(key, f[(c + 1) % 3]);
  }
  let refinedLoop = [];
  try { refinedLoop = boundaryLoop(mf); } catch (e) { fail("refined mesh boundary: " + e.message); }
  const undirected = new Set();
  for (const f of mf) for (let c = 0; c < 3; c++) {
    const a = f[c], b = f[(c + 1) % 3];
    undirected.add(Math.min(a, b) + "," + Math.max(a, b));
  }
  const used = new Set(mf.flat());
  if (used.size - undirected.size + mf.length !== 1) fail(`refined mesh Euler characteristic ${used.size - undirected.size + mf.length} != 1`);

  // 2. no inserted vertex on the boundary; boundary uv = the prescribed positions, bit for bit
  const loop = boundaryLoop(F);
  const positions = request.boundary.positions;
  if (JSON.stringify(answer.boundary_loop) !== JSON.stringify(loop)) fail("boundary_loop is not the mesh's boundary loop from its lowest vertex");
  if (refinedLoop.length !== loop.length || refinedLoop.some((v, k) => v !== loop[k])) fail("the refined mesh's boundary is not the original boundary loop (inserted vertex on the boundary?)");
  loop.forEach((v, k) => {
    if (uv[v][0] !== positions[k][0] || uv[v][1] !== positions[k][1]) fail(`boundary vertex ${v}: uv ${uv[v]} != prescribed ${positions[k]}`);
  });

  // 3. every triangle strictly positive in uv, by an exact predicate
  let negative = 0;
  mf.forEach((f, i) => {
    if (orientSign(uv[f[0]], uv[f[1]], uv[f[2]]) <= 0) { negative++; if (negative <= 3) fail(`face ${i} ${f} is not positive in uv`); }
  });
  if (negative > 3) fail(`${negative} faces are not positive in uv`);

  // 4. interior vertices: uv angles sum to 2 pi (one turn)
  const onBoundary = new Set(refinedLoop);
  const angleSum = new Float64Array(mv.length);
  for (const f of mf) for (let c = 0; c < 3; c++) {
    const p = uv[f[c]], q = uv[f[(c + 1) % 3]], r = uv[f[(c + 2) % 3]];
    const ux = q[0] - p[0], uy = q[1] - p[1], vx = r[0] - p[0], vy = r[1] - p[1];
    angleSum[f[c]] += Math.atan2(ux * vy - uy * vx, ux * vx + uy * vy);
  }
  let badTurns = 0;
  for (const v of used) if (!onBoundary.has(v) && Math.abs(angleSum[v] - 2 * Math.PI) > 1e-6) { badTurns++; if (badTurns <= 3) fail(`interior vertex ${v}: uv angles sum to ${angleSum[v]}, not 2 pi`); }

  // 5. no triangle with all three corners on one original edge; 3D area preserved
  const onEdge = (v) => (v < n ? null : ins[v - n].edge);
  mf.forEach((f, i) => {
    // the original edges every corner lies on: an inserted corner names one; an original corner lies on all its edges
    const insertedEdges = f.map(onEdge).filter((e) => e !== null).map((e) => e[0] + "," + e[1]);
    const originals = f.filter((v) => v < n);
    let candidates;
    if (insertedEdges.length) {
      if (new Set(insertedEdges).size !== 1) return;
      candidates = [insertedEdges[0]];
    } else {
      return; // three original vertices are never on one edge (no degenerate input face)
    }
    const [a, b] = candidates[0].split(",").map(Number);
    if (originals.every((v) => v === a || v === b)) fail(`face ${i} ${f} has all corners on original edge (${a}, ${b})`);
  });
  const area = (verts, faces) => faces.reduce((s, f) => s + triangleArea3(verts[f[0]], verts[f[1]], verts[f[2]]), 0);
  const a0 = area(V, F), a1 = area(mv, mf);
  if (Math.abs(a1 - a0) > 1e-9 * a0) fail(`3D area ${a1} != ${a0}`);
  return errors;
}

// ---- Prometheus text format --------------------------------------------------------------------------

const FAMILIES = ["lipmap_http_requests_total", "lipmap_http_request_duration_seconds", "lipmap_queue_depth",
  "lipmap_workers", "lipmap_workers_busy", "lipmap_jobs", "lipmap_engine_stage_seconds", "lipmap_inserted_vertices_total"];

function checkMetrics(text) {
  const errors = [];
  const sample = /^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[a-zA-Z_][a-zA-Z0-9_]*="(?:\\.|[^"\\])*"(?:,[a-zA-Z_][a-zA-Z0-9_]*="(?:\\.|[^"\\])*")*\})? (NaN|[+-]Inf|[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)$/;
  const typed = new Set();
  for (const line of text.split("\n")) {
    if (line === "") continue;
    let m;
    if ((m = /^# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|histogram|summary|untyped)$/.exec(line))) typed.add(m[1]);
    else if (/^# HELP [a-zA-Z_:][a-zA-Z0-9_:]* .*$/.test(line)) continue;
    else if (!sample.test(line)) errors.push(`not Prometheus text: ${JSON.stringify(line)}`);
  }
  for (const f of FAMILIES) if (!typed.has(f)) errors.push(`metric family ${f} missing`);
  return errors;
}

// ---- main ----------------------------------------------------------------------------------------------

function main() {
  const manifest = process.argv[2];
  if (!manifest) { console.error("usage: check_answers.js MANIFEST"); process.exit(2); }
  const lines = fs.readFileSync(manifest, "utf8").split("\n").filter((l) => l.trim());
  const ajv = loadAjv();
  let failures = 0;
  const read = (f) => fs.readFileSync(f, "utf8");
  for (const line of lines) {
    const [kind, a, b] = line.trim().split(/\s+/);
    let errors = [];
    try {
      if (kind === "schema") {
        const validate = ajv.getSchema(a);
        if (!validate) errors = [`no schema ${a}`];
        else if (!validate(JSON.parse(read(b))))
          errors = validate.errors.map((e) => `${e.instancePath || "(root)"} ${e.message} ${JSON.stringify(e.params)}`);
      } else if (kind === "map") {
        errors = checkMap(JSON.parse(read(a)), JSON.parse(read(b)));
      } else if (kind === "metrics") {
        errors = checkMetrics(read(a));
      } else {
        errors = [`unknown check ${kind}`];
      }
    } catch (e) {
      errors = [e.message];
    }
    if (errors.length) {
      failures++;
      console.error(`check_answers: FAILED ${line}`);
      for (const e of errors.slice(0, 10)) console.error(`  ${e}`);
    }
  }
  if (failures) process.exit(1);
  console.log(`check_answers: ${lines.length} checks passed`);
}

module.exports = { checkMap, orientSign, exactOrientSign, checkMetrics };
if (require.main === module) main();
