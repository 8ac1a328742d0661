#!/usr/bin/env node
// glTF inputs and boundary targets for the glTF bats tests (tests only; everything is made at test time into a
// temp dir, nothing large is committed). Independent of lipmap: its own OFF/OBJ reader, glTF writer, Tutte map
// and exact orientation test.
//
//   node gltf_fixture.js model MESH.off|MESH.obj OUT.glb|OUT.gltf [--split-seam] [--non-indexed] [--mode N]
//       MESH as glTF 2.0: POSITION (float32), NORMAL (area-weighted, unit), COLOR_0 (VEC4 float from the
//       position), TEXCOORD_0 and TEXCOORD_1 (planar projections), UNSIGNED_INT indices (or none with
//       --non-indexed), a material with a 1x1 PNG base colour texture, and a second untouched mesh on a
//       second node. --split-seam duplicates every vertex shared by the faces left and right of the median
//       centroid x (the right faces use the copies), as exporters split vertices at uv seams.
//   node gltf_fixture.js target MESH.off|MESH.obj|MESH.glb|MESH.gltf circle|exp OUT.json [--weld]
//       A boundary document {"vertices": loop, "positions": [[u, v]...]} for MESH's boundary loop (interior on
//       the left, from its lowest vertex): circle by 3D arc length (simple), or exp: a uniform Tutte map of the
//       mesh onto an ellipse followed by z -> exp(c z), wrapping 1.1 to 1.5 turns, certified here (every image
//       triangle strictly positive by an exact test, interior angle sums 2 pi, boundary not simple): a
//       self-overlapping boundary by construction. Prints the kind and parameters used on standard error.
//       A glTF MESH is its mesh 0 primitive 0 as lipmap sees it (used vertices in index order; with --weld,
//       vertices of bit-identical POSITION merged into the lowest-index one).
//   node gltf_fixture.js corrupt KIND IN.glb|IN.gltf OUT
//       A broken copy: truncated, magic, buffer_range (a bufferView past its buffer), accessor_type (POSITION
//       declared VEC2), no_triangles (2 indices), mode_lines, mode_strip, external_uri (buffer in a file).
"use strict";

const fs = require("fs");

// ---- meshes ------------------------------------------------------------------------------------------------

function readMesh(file) {
  const text = fs.readFileSync(file, "utf8").replace(/\r/g, "");
  const vertices = [], faces = [];
  if (file.toLowerCase().endsWith(".off")) {
    const tokens = text.split("\n").map((l) => l.replace(/#.*/, "").trim()).filter((l) => l).join(" ").split(/\s+/);
    let i = 0;
    if (tokens[i] === "OFF") i++;
    const nv = +tokens[i++], nf = +tokens[i++];
    i++;
    for (let v = 0; v < nv; v++, i += 3) vertices.push([+tokens[i], +tokens[i + 1], +tokens[i + 2]].map(Math.fround));
    for (let f = 0; f < nf; f++) {
      const n = +tokens[i++];
      const face = [];
      for (let c = 0; c < n; c++) face.push(+tokens[i++]);
      faces.push(face);
    }
  } else {
    for (const line of text.split("\n")) {
      const t = line.trim().split(/\s+/);
      if (t[0] === "v") vertices.push([+t[1], +t[2], +t[3]].map(Math.fround));
      else if (t[0] === "f") faces.push(t.slice(1).map((x) => parseInt(x.split("/")[0], 10) - 1));
    }
  }
  for (const f of faces) if (f.length !== 3) throw new Error(`${file}: not a triangle mesh`);
  return { vertices, faces };
}

// Boundary loop: directed edges without a twin, chained from the lowest vertex (interior on the left).
function boundaryLoop(faces) {
  const directed = new Set();
  for (const f of faces) for (let c = 0; c < 3; c++) directed.add(f[c] + "," + f[(c + 1) % 3]);
  const next = new Map();
  for (const f of faces)
    for (let c = 0; c < 3; c++) {
      const a = f[c], b = f[(c + 1) % 3];
      if (!directed.has(b + "," + a)) next.set(a, b);
    }
  const start = Math.min(...next.keys());
  const loop = [start];
  for (let v = next.get(start); v !== start; v = next.get(v)) loop.push(v);
  return loop;
}

// ---- glTF writing ------------------------------------------------------------------------------------------

const PNG_1x1 = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==";

function attributesOf(mesh) {
  const { vertices, faces } = mesh;
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const p of vertices) for (let i = 0; i < 3; i++) (lo[i] = Math.min(lo[i], p[i])), (hi[i] = Math.max(hi[i], p[i]));
  const unit = (i, x) => (hi[i] > lo[i] ? (x - lo[i]) / (hi[i] - lo[i]) : 0.5);
  const normal = vertices.map(() => [0, 0, 0]);
  for (const [a, b, c] of faces) {
    const A = vertices[a], B = vertices[b], C = vertices[c];
    const u = [B[0] - A[0], B[1] - A[1], B[2] - A[2]], w = [C[0] - A[0], C[1] - A[1], C[2] - A[2]];
    const n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
    for (const v of [a, b, c]) for (let i = 0; i < 3; i++) normal[v][i] += n[i];
  }
  return {
    NORMAL: normal.map((n) => {
      const l = Math.hypot(n[0], n[1], n[2]);
      return l > 0 ? n.map((x) => x / l) : [0, 0, 1];
    }),
    COLOR_0: vertices.map((p) => [unit(0, p[0]), unit(1, p[1]), unit(2, p[2]), 1]),
    TEXCOORD_0: vertices.map((p) => [unit(0, p[0]), 1 - unit(1, p[1])]),
    TEXCOORD_1: vertices.map((p) => [0.5 * unit(2, p[2]), unit(0, p[0])]),
  };
}

function writeGltf(mesh, out, opts = {}) {
  let { vertices, faces } = mesh;
  const attrs = attributesOf(mesh);
  let origin = vertices.map((_, i) => i);
  if (opts.splitSeam) {
    const cx = faces.map((f) => f.reduce((s, v) => s + vertices[v][0], 0));
    const median = [...cx].sort((a, b) => a - b)[Math.floor(cx.length / 2)];
    const mask = new Array(vertices.length).fill(0);
    faces.forEach((f, i) => f.forEach((v) => (mask[v] |= cx[i] < median ? 1 : 2)));
    const copy = new Map();
    vertices = vertices.slice();
    faces = faces.map((f, i) =>
      cx[i] < median ? f : f.map((v) => {
        if (mask[v] !== 3) return v;
        if (!copy.has(v)) {
          copy.set(v, vertices.length);
          vertices.push(vertices[v]);
          origin.push(v);
        }
        return copy.get(v);
      }));
  }
  if (opts.nonIndexed) {
    const soup = [], soupOrigin = [];
    faces = faces.map((f) => f.map((v) => (soup.push(vertices[v]), soupOrigin.push(origin[v]), soup.length - 1)));
    vertices = soup;
    origin = soupOrigin;
  }
  const chunks = [], views = [], accessors = [];
  let length = 0;
  function add(array, type, componentType, target, count, bounds) {
    const pad = (4 - (length % 4)) % 4;
    if (pad) chunks.push(Buffer.alloc(pad)), (length += pad);
    const bytes = Buffer.from(array.buffer, array.byteOffset, array.byteLength);
    views.push({ buffer: 0, byteOffset: length, byteLength: bytes.length, target });
    chunks.push(bytes);
    length += bytes.length;
    const acc = { bufferView: views.length - 1, componentType, count, type };
    if (bounds) Object.assign(acc, bounds);
    accessors.push(acc);
    return accessors.length - 1;
  }
  const flat = (rows) => new Float32Array(rows.flat());
  const lo = [0, 1, 2].map((i) => Math.min(...vertices.map((p) => p[i])));
  const hi = [0, 1, 2].map((i) => Math.max(...vertices.map((p) => p[i])));
  const attributes = { POSITION: add(flat(vertices), "VEC3", 5126, 34962, vertices.length, { min: lo, max: hi }) };
  for (const [name, rows] of Object.entries(attrs)) {
    const r = origin.map((o) => rows[o]);
    attributes[name] = add(flat(r), ["", "", "VEC2", "VEC3", "VEC4"][r[0].length], 5126, 34962, r.length);
  }
  const primitive = { attributes, material: 0 };
  if (opts.mode !== undefined && opts.mode !== 4) primitive.mode = opts.mode;
  if (!opts.nonIndexed) primitive.indices = add(new Uint32Array(faces.flat()), "SCALAR", 5125, 34963, faces.length * 3);
  const tri = add(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]), "VEC3", 5126, 34962, 3, { min: [0, 0, 0], max: [1, 1, 0] });
  const pad = (4 - (length % 4)) % 4;
  if (pad) chunks.push(Buffer.alloc(pad)), (length += pad);
  const bin = Buffer.concat(chunks);
  const doc = {
    asset: { version: "2.0", generator: "lipmap test fixture (js)" },
    scene: 0,
    scenes: [{ nodes: [0, 1] }],
    nodes: [{ name: "fixture", mesh: 0 }, { name: "untouched", mesh: 1, translation: [3, 0, 0] }],
    meshes: [{ name: "fixture", primitives: [primitive] }, { name: "untouched", primitives: [{ attributes: { POSITION: tri } }] }],
    materials: [{ name: "fixture material", pbrMetallicRoughness: { baseColorTexture: { index: 0 }, metallicFactor: 0 } }],
    textures: [{ source: 0, sampler: 0 }],
    samplers: [{ magFilter: 9729, minFilter: 9729 }],
    images: [{ uri: "data:image/png;base64," + PNG_1x1 }],
    bufferViews: views,
    accessors,
    buffers: [{ byteLength: bin.length }],
  };
  if (out.toLowerCase().endsWith(".gltf")) {
    doc.buffers[0].uri = "data:application/octet-stream;base64," + bin.toString("base64");
    fs.writeFileSync(out, JSON.stringify(doc));
    return;
  }
  fs.writeFileSync(out, glb(doc, bin));
}

function glb(doc, bin) {
  let json = Buffer.from(JSON.stringify(doc));
  if (json.length % 4) json = Buffer.concat([json, Buffer.alloc(4 - (json.length % 4), " ")]);
  const header = Buffer.alloc(12);
  header.write("glTF", 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + json.length + (bin.length ? 8 + bin.length : 0), 8);
  const jh = Buffer.alloc(8);
  jh.writeUInt32LE(json.length, 0);
  jh.writeUInt32LE(0x4e4f534a, 4);
  const parts = [header, jh, json];
  if (bin.length) {
    const bh = Buffer.alloc(8);
    bh.writeUInt32LE(bin.length, 0);
    bh.writeUInt32LE(0x004e4942, 4);
    parts.push(bh, bin);
  }
  return Buffer.concat(parts);
}

// Splits a .glb or .gltf into its JSON and binary buffer 0.
function readGltf(file) {
  const bytes = fs.readFileSync(file);
  if (bytes.slice(0, 4).toString() === "glTF") {
    const n = bytes.readUInt32LE(12);
    const doc = JSON.parse(bytes.slice(20, 20 + n).toString());
    const at = 20 + n;
    const bin = at + 8 <= bytes.length ? bytes.slice(at + 8, at + 8 + bytes.readUInt32LE(at)) : Buffer.alloc(0);
    return { doc, bin, binary: true };
  }
  const doc = JSON.parse(bytes.toString());
  const uri = doc.buffers[0].uri;
  return { doc, bin: Buffer.from(uri.slice(uri.indexOf(",") + 1), "base64"), binary: false };
}

function writeBack(file, { doc, bin, binary }) {
  if (binary) fs.writeFileSync(file, glb(doc, bin));
  else {
    if (!doc.buffers[0].uri.startsWith("data:") || doc.buffers[0].uri.length < 100) {
      fs.writeFileSync(file, JSON.stringify(doc));
      return;
    }
    doc.buffers[0].uri = "data:application/octet-stream;base64," + bin.toString("base64");
    fs.writeFileSync(file, JSON.stringify(doc));
  }
}

function corrupt(kind, input, out) {
  const g = readGltf(input);
  const prim = g.doc.meshes[0].primitives[0];
  switch (kind) {
    case "truncated": {
      const bytes = fs.readFileSync(input);
      fs.writeFileSync(out, bytes.slice(0, Math.floor(bytes.length / 2)));
      return;
    }
    case "magic": {
      const bytes = Buffer.from(fs.readFileSync(input));
      bytes.write("glTX", 0);
      fs.writeFileSync(out, bytes);
      return;
    }
    case "buffer_range":
      g.doc.accessors[prim.attributes.NORMAL].byteOffset = 8;
      break;
    case "accessor_type":
      g.doc.accessors[prim.attributes.POSITION].type = "VEC2";
      break;
    case "no_triangles":
      g.doc.accessors[prim.indices].count = 2;
      break;
    case "mode_lines":
      prim.mode = 1;
      break;
    case "mode_strip":
      prim.mode = 5;
      break;
    case "external_uri":
      g.doc.buffers[0].uri = "model.bin";
      if (g.binary) throw new Error("external_uri: give a .gltf");
      fs.writeFileSync(out, JSON.stringify(g.doc));
      return;
    default:
      throw new Error("unknown corruption " + kind);
  }
  writeBack(out, g);
}

// ---- targets -----------------------------------------------------------------------------------------------

function arcFractions(mesh, loop) {
  const d = [0];
  for (let k = 1; k <= loop.length; k++) {
    const a = mesh.vertices[loop[k - 1]], b = mesh.vertices[loop[k % loop.length]];
    d.push(d[k - 1] + Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]));
  }
  return loop.map((_, k) => d[k] / d[loop.length]);
}

// Uniform Tutte map onto the unit circle (boundary by arc length), conjugate gradients per coordinate.
function tutte(mesh, loop) {
  const n = mesh.vertices.length;
  const nbr = Array.from({ length: n }, () => new Set());
  for (const [a, b, c] of mesh.faces) for (const [x, y] of [[a, b], [b, c], [c, a]]) nbr[x].add(y), nbr[y].add(x);
  const fixed = new Map();
  arcFractions(mesh, loop).forEach((s, k) => fixed.set(loop[k], [Math.cos(2 * Math.PI * s), Math.sin(2 * Math.PI * s)]));
  const inner = [...Array(n).keys()].filter((v) => !fixed.has(v));
  const index = new Map(inner.map((v, i) => [v, i]));
  const result = mesh.vertices.map((_, v) => (fixed.has(v) ? fixed.get(v).slice() : [0, 0]));
  for (const dim of [0, 1]) {
    const m = inner.length;
    const apply = (x) => inner.map((v, i) => {
      let s = nbr[v].size * x[i];
      for (const w of nbr[v]) if (index.has(w)) s -= x[index.get(w)];
      return s;
    });
    const b = inner.map((v) => {
      let s = 0;
      for (const w of nbr[v]) if (fixed.has(w)) s += fixed.get(w)[dim];
      return s;
    });
    let x = new Array(m).fill(0), r = b.slice(), p = r.slice();
    let rr = r.reduce((s, y) => s + y * y, 0);
    const stop = 1e-26 * Math.max(1, rr);
    for (let it = 0; it < 20 * m + 100 && rr > stop; it++) {
      const Ap = apply(p);
      const alpha = rr / p.reduce((s, y, i) => s + y * Ap[i], 0);
      x = x.map((y, i) => y + alpha * p[i]);
      r = r.map((y, i) => y - alpha * Ap[i]);
      const rr2 = r.reduce((s, y) => s + y * y, 0);
      p = r.map((y, i) => y + (rr2 / rr) * p[i]);
      rr = rr2;
    }
    inner.forEach((v, i) => (result[v][dim] = x[i]));
  }
  return result;
}

// Exact sign of the orientation of three points with double coordinates (BigInt arithmetic).
function exactOrient(a, b, c) {
  const big = (x) => {
    if (x === 0) return { m: 0n, e: 0 };
    const view = new DataView(new ArrayBuffer(8));
    view.setFloat64(0, x);
    const hi = view.getUint32(0), lo = view.getUint32(4);
    const biased = (hi >>> 20) & 0x7ff;
    let m = (BigInt(hi & 0xfffff) << 32n) | BigInt(lo);
    let e;
    if (biased === 0) e = -1074;
    else (m |= 1n << 52n), (e = biased - 1075);
    return { m: hi >>> 31 ? -m : m, e };
  };
  const pts = [a[0], a[1], b[0], b[1], c[0], c[1]].map(big);
  const emin = Math.min(...pts.map((p) => p.e));
  const v = pts.map((p) => p.m << BigInt(p.e - emin));
  const det = (v[2] - v[0]) * (v[5] - v[1]) - (v[3] - v[1]) * (v[4] - v[0]);
  return det > 0n ? 1 : det < 0n ? -1 : 0;
}

function angleSumsOk(mesh, uv, loop) {
  const onBoundary = new Set(loop);
  const theta = new Array(mesh.vertices.length).fill(0);
  for (const f of mesh.faces)
    for (let c = 0; c < 3; c++) {
      const a = uv[f[c]], b = uv[f[(c + 1) % 3]], d = uv[f[(c + 2) % 3]];
      const ux = b[0] - a[0], uy = b[1] - a[1], wx = d[0] - a[0], wy = d[1] - a[1];
      theta[f[c]] += Math.abs(Math.atan2(ux * wy - uy * wx, ux * wx + uy * wy));
    }
  return theta.every((t, v) => onBoundary.has(v) || Math.abs(t - 2 * Math.PI) < 1e-7);
}

function segmentsCross(p, q, r, s) {
  const o = (a, b, c) => exactOrient(a, b, c);
  return o(p, q, r) * o(p, q, s) < 0 && o(r, s, p) * o(r, s, q) < 0;
}

function isSimple(poly) {
  const n = poly.length;
  for (let i = 0; i < n; i++)
    for (let j = i + 2; j < n; j++) {
      if (i === 0 && j === n - 1) continue;
      if (segmentsCross(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n])) return false;
    }
  return true;
}

function target(mesh, kind) {
  const loop = boundaryLoop(mesh.faces);
  if (kind === "circle") {
    const s = arcFractions(mesh, loop);
    return { vertices: loop, positions: s.map((x) => [Math.cos(2 * Math.PI * x), Math.sin(2 * Math.PI * x)]) };
  }
  if (kind !== "exp") throw new Error("unknown target kind " + kind);
  const disk = tutte(mesh, loop);
  for (const [turns, a, b] of [[1.5, 0.75, 2.0], [1.3, 1.0, 1.6], [1.15, 1.2, 1.4], [1.1, 1.5, 1.5]]) {
    const c = (turns * 2 * Math.PI) / (2 * b);
    const uv = disk.map(([x, y]) => {
      const r = Math.exp(c * a * x);
      return [r * Math.cos(c * b * y), r * Math.sin(c * b * y)];
    });
    if (!mesh.faces.every(([p, q, r]) => exactOrient(uv[p], uv[q], uv[r]) > 0)) continue;
    if (!angleSumsOk(mesh, uv, loop)) continue;
    const poly = loop.map((v) => uv[v]);
    if (isSimple(poly)) continue;
    process.stderr.write(`gltf_fixture: exp target with ${turns} turns, ellipse ${a} x ${b}\n`);
    return { vertices: loop, positions: poly };
  }
  throw new Error("no certified exp target for this mesh");
}

function meshFromGltf(file, weld) {
  const g = readGltf(file);
  const prim = g.doc.meshes[0].primitives[0];
  const read = (index, comps) => {
    const a = g.doc.accessors[index], v = g.doc.bufferViews[a.bufferView];
    const out = [];
    for (let i = 0; i < a.count; i++) {
      const row = [];
      for (let c = 0; c < comps; c++) {
        const at = (v.byteOffset || 0) + (a.byteOffset || 0) + i * (v.byteStride || comps * 4) + 4 * c;
        row.push(a.componentType === 5126 ? g.bin.readFloatLE(at) : g.bin.readUInt32LE(at));
      }
      out.push(row);
    }
    return out;
  };
  const pos = read(prim.attributes.POSITION, 3);
  const idx = prim.indices !== undefined ? read(prim.indices, 1).map((r) => r[0]) : [...pos.keys()];
  const used = new Set(idx), cls = new Map(), byPos = new Map(), vertices = [];
  for (let v = 0; v < pos.length; v++) {
    if (!used.has(v)) continue;
    const key = pos[v].join(",");
    if (weld && byPos.has(key)) {
      cls.set(v, byPos.get(key));
      continue;
    }
    byPos.set(key, vertices.length);
    cls.set(v, vertices.length);
    vertices.push(pos[v]);
  }
  const faces = [];
  for (let i = 0; i < idx.length; i += 3) faces.push([cls.get(idx[i]), cls.get(idx[i + 1]), cls.get(idx[i + 2])]);
  return { vertices, faces };
}

function main(argv) {
  const [what, ...rest] = argv;
  if (what === "model") {
    const [meshFile, out, ...flags] = rest;
    const opts = { splitSeam: flags.includes("--split-seam"), nonIndexed: flags.includes("--non-indexed") };
    const m = flags.indexOf("--mode");
    if (m >= 0) opts.mode = +flags[m + 1];
    writeGltf(readMesh(meshFile), out, opts);
  } else if (what === "target") {
    const [meshFile, kind, out, ...flags] = rest;
    const mesh = /\.gl(b|tf)$/i.test(meshFile) ? meshFromGltf(meshFile, flags.includes("--weld")) : readMesh(meshFile);
    fs.writeFileSync(out, JSON.stringify(target(mesh, kind)));
  } else if (what === "corrupt") {
    const [kind, input, out] = rest;
    corrupt(kind, input, out);
  } else {
    console.error("usage: gltf_fixture.js model|target|corrupt ... (see the header)");
    process.exit(2);
  }
}

module.exports = { readMesh, boundaryLoop, readGltf, exactOrient, attributesOf };
if (require.main === module) main(process.argv.slice(2));
