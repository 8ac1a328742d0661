#!/usr/bin/env node
// Checks a glTF that lipmap wrote against the glTF it was given (tests only), on the uv AS STORED (float32):
//
//   node gltf_check_map.js OUT.glb|OUT.gltf IN.glb|IN.gltf BOUNDARY.json|texcoord:N [--weld] [--mesh M] [--primitive P]
//
// BOUNDARY.json is the boundary document sent ({"vertices"?, "positions"}); texcoord:N means the boundary was
// pinned to IN's TEXCOORD_N. --weld: the input's vertices with bit-identical POSITION were merged (lowest
// index first), as lipmap's weld=position does. Checks (docs/contract.md on the float32 uv, in lipmap's
// convention (u, v) = (s, 1 - t), TEXCOORD_0 = (s, t)):
//   - the output primitive is a disk whose boundary is the input's loop (same vertices, same direction);
//   - original vertices keep their index and POSITION bits; inserted ones (extras.lipmap.inserted) lie on
//     an interior original edge, 0 < t < 1;
//   - boundary TEXCOORD_0 is exactly the float32 of the targets: (fround(u), fround(1 - v));
//   - every triangle is strictly clockwise in (s, t) (= counterclockwise in (u, v)), by an exact test on the
//     stored floats; every interior vertex's angles sum to 2 pi;
//   - NORMAL and COLOR_0 of every inserted vertex equal the interpolation of its edge's endpoints (normal
//     renormalized), as float32; TEXCOORD_1 likewise.
// Prints "gltf_check_map: ok ..." or every failure (exit 1).
"use strict";

const fs = require("fs");
const { readGltf, exactOrient } = require("./gltf_fixture.js");

function accessor(g, index) {
  const a = g.doc.accessors[index];
  const v = g.doc.bufferViews[a.bufferView];
  const comps = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 }[a.type];
  const size = { 5121: 1, 5123: 2, 5125: 4, 5126: 4 }[a.componentType];
  const stride = v.byteStride || comps * size;
  const base = (v.byteOffset || 0) + (a.byteOffset || 0);
  const rows = [];
  for (let i = 0; i < a.count; i++) {
    const row = [];
    for (let c = 0; c < comps; c++) {
      const at = base + i * stride + c * size;
      row.push(a.componentType === 5126 ? g.bin.readFloatLE(at) : a.componentType === 5125 ? g.bin.readUInt32LE(at)
        : a.componentType === 5123 ? g.bin.readUInt16LE(at) : g.bin.readUInt8(at));
    }
    rows.push(row);
  }
  return rows;
}

function primitiveOf(g, mesh, primitive) {
  const p = g.doc.meshes[mesh].primitives[primitive];
  const attrs = {};
  for (const [name, index] of Object.entries(p.attributes)) attrs[name] = accessor(g, index);
  const n = attrs.POSITION.length;
  const idx = p.indices !== undefined ? accessor(g, p.indices).map((r) => r[0]) : [...Array(n).keys()];
  const faces = [];
  for (let i = 0; i < idx.length; i += 3) faces.push([idx[i], idx[i + 1], idx[i + 2]]);
  return { attrs, faces, extras: p.extras || {} };
}

// The engine's view of an input primitive: used vertices (welded by position when asked), in index order.
function engineMesh(prim, weld) {
  const used = new Set(prim.faces.flat());
  const cls = new Map(), rep = [], byPos = new Map();
  for (let v = 0; v < prim.attrs.POSITION.length; v++) {
    if (!used.has(v)) continue;
    const key = prim.attrs.POSITION[v].map((x) => Object.is(x, -0) ? "-0" : String(x)).join(",");
    if (weld && byPos.has(key)) {
      cls.set(v, byPos.get(key));
      continue;
    }
    byPos.set(key, rep.length);
    cls.set(v, rep.length);
    rep.push(v);
  }
  const attrs = {};
  for (const [name, rows] of Object.entries(prim.attrs)) attrs[name] = rep.map((v) => rows[v]);
  return { attrs, faces: prim.faces.map((f) => f.map((v) => cls.get(v))) };
}

function loopOf(faces) {
  const directed = new Set();
  for (const f of faces) for (let c = 0; c < 3; c++) directed.add(f[c] + "," + f[(c + 1) % 3]);
  const next = new Map();
  for (const f of faces)
    for (let c = 0; c < 3; c++) {
      const a = f[c], b = f[(c + 1) % 3];
      if (!directed.has(b + "," + a)) {
        if (next.has(a)) return null;
        next.set(a, b);
      }
    }
  if (next.size === 0) return null;
  const start = Math.min(...next.keys());
  const loop = [start];
  for (let v = next.get(start); v !== start; v = next.get(v)) {
    if (v === undefined || loop.length > next.size) return null;
    loop.push(v);
  }
  return loop.length === next.size ? loop : null;
}

function main(argv) {
  const [outFile, inFile, boundarySpec, ...flags] = argv;
  const weld = flags.includes("--weld");
  const opt = (name) => (flags.indexOf(name) >= 0 ? +flags[flags.indexOf(name) + 1] : 0);
  const meshIndex = opt("--mesh"), primIndex = opt("--primitive");
  const errors = [];
  const fail = (s) => errors.length < 40 && errors.push(s);

  const input = engineMesh(primitiveOf(readGltf(inFile), meshIndex, primIndex), weld);
  const out = primitiveOf(readGltf(outFile), meshIndex, primIndex);
  const n0 = input.attrs.POSITION.length;
  const nv = out.attrs.POSITION.length;
  const inserted = (out.extras.lipmap && out.extras.lipmap.inserted) || [];
  if (!out.extras.lipmap) fail("no extras.lipmap on the primitive");
  if (nv !== n0 + inserted.length) fail(`${nv} vertices, expected ${n0} original + ${inserted.length} inserted`);

  const loop = loopOf(input.faces);
  const outLoop = loopOf(out.faces);
  if (!loop || !outLoop) fail("the input or the output primitive has no single boundary loop");
  else if (outLoop.join(",") !== loop.join(",")) fail("the output's boundary loop is not the input's");

  // Targets.
  let targets;
  if (boundarySpec.startsWith("texcoord:")) {
    const set = input.attrs["TEXCOORD_" + boundarySpec.slice(9)];
    targets = loop.map((v) => [set[v][0], 1 - set[v][1]]);
  } else {
    const b = JSON.parse(fs.readFileSync(boundarySpec, "utf8"));
    if (b.vertices && b.vertices.join(",") !== loop.join(",")) fail("the boundary document's vertices are not the loop from its lowest vertex");
    targets = b.positions;
  }
  const st = out.attrs.TEXCOORD_0;
  if (!st) fail("no TEXCOORD_0");
  else
    loop.forEach((v, k) => {
      const want = [Math.fround(targets[k][0]), Math.fround(1 - targets[k][1])];
      if (st[v][0] !== want[0] || st[v][1] !== want[1])
        fail(`boundary vertex ${v} (loop ${k}): TEXCOORD_0 (${st[v]}), want the float32 of the target (${want})`);
    });

  // Original vertices, inserted vertices.
  for (let v = 0; v < Math.min(n0, nv); v++)
    if (out.attrs.POSITION[v].some((x, i) => !Object.is(x, input.attrs.POSITION[v][i]))) fail(`vertex ${v} moved`);
  const edgeFaces = new Map();
  for (const f of input.faces)
    for (let c = 0; c < 3; c++) {
      const a = Math.min(f[c], f[(c + 1) % 3]), b = Math.max(f[c], f[(c + 1) % 3]);
      edgeFaces.set(a + "," + b, (edgeFaces.get(a + "," + b) || 0) + 1);
    }
  const lerp = (x, y, t) => x.map((xi, i) => (1 - t) * xi + t * y[i]);
  inserted.forEach((ins, i) => {
    const [a, b] = ins.edge, t = ins.t, p = n0 + i;
    if (!(a < b) || edgeFaces.get(a + "," + b) !== 2 || !(t > 0 && t < 1)) fail(`inserted ${p}: edge (${a}, ${b}) t ${t} is not on an interior original edge`);
    if (input.attrs.NORMAL && out.attrs.NORMAL) {
      const e = lerp(input.attrs.NORMAL[a], input.attrs.NORMAL[b], t);
      const l = Math.hypot(...e);
      out.attrs.NORMAL[p].forEach((x, k) => Math.abs(x - e[k] / l) > 2e-7 && fail(`inserted ${p}: NORMAL ${out.attrs.NORMAL[p]} != normalized lerp ${e.map((y) => y / l)}`));
    }
    for (const name of ["COLOR_0", "TEXCOORD_1"]) {
      if (!input.attrs[name] || !out.attrs[name]) continue;
      const e = lerp(input.attrs[name][a], input.attrs[name][b], t).map(Math.fround);
      if (out.attrs[name][p].some((x, k) => x !== e[k])) fail(`inserted ${p}: ${name} ${out.attrs[name][p]} != lerp ${e}`);
    }
  });

  // Orientation (exact, on the stored floats) and angle sums.
  if (st) {
    let bad = 0;
    out.faces.forEach((f, i) => {
      if (exactOrient(st[f[0]], st[f[1]], st[f[2]]) >= 0) bad++ < 5 && fail(`face ${i} (${f}) is not strictly clockwise in (s, t)`);
    });
    if (bad) fail(`${bad} faces not strictly positive in lipmap's uv`);
    const onBoundary = new Set(outLoop || []);
    const theta = new Array(nv).fill(0);
    const uv = st.map(([s, t]) => [s, 1 - t]);
    for (const f of out.faces)
      for (let c = 0; c < 3; c++) {
        const a = uv[f[c]], b = uv[f[(c + 1) % 3]], d = uv[f[(c + 2) % 3]];
        const ux = b[0] - a[0], uy = b[1] - a[1], wx = d[0] - a[0], wy = d[1] - a[1];
        theta[f[c]] += Math.abs(Math.atan2(ux * wy - uy * wx, ux * wx + uy * wy));
      }
    theta.forEach((t, v) => !onBoundary.has(v) && Math.abs(t - 2 * Math.PI) > 1e-6 && fail(`interior vertex ${v}: angle sum ${t}`));
  }
  if (errors.length) {
    console.log(`gltf_check_map: ${outFile}: FAILED\n  ` + errors.join("\n  "));
    return 1;
  }
  console.log(`gltf_check_map: ok ${outFile}: ${nv} vertices (${inserted.length} inserted), ${out.faces.length} faces`);
  return 0;
}

process.exit(main(process.argv.slice(2)));
