#!/usr/bin/env node
// Builds request bodies for the HTTP tests and benchmarks (test-only; never shipped).
//
//   node make_request.js grid N BOUNDARY [--z bump|flat] [--method tutte|harmonic] [--no-refine]
//       An N x N-vertex grid on [0,1]^2 (2 (N-1)^2 triangles), lifted to a bump in 3D unless --z flat,
//       with boundary positions for its boundary loop (interior on the left, starting at vertex 0):
//         square     the grid's own outline scaled by 2: simple
//         circle     the loop spread evenly on a circle: simple (convex)
//         spiral     the image of the grid under (x, y) -> (2 - y) (cos 2.5 pi x, sin 2.5 pi x), an annulus
//                    sector wound 1.25 turns: self-overlapping by construction (locally injective, not injective)
//         clockwise  the square traversed backwards: not self-overlapping (turning number -1)
//         figure8    a figure-eight curve: not self-overlapping (turning number 0)
//   node make_request.js mesh FILE.off|FILE.obj [circle]
//       A mesh file (triangles only), with its boundary loop spread on a circle. The loop is found here,
//       independently of the engine.
//   node make_request.js invalid KIND
//       A parametrize body whose mesh the validate stage must refuse: nonmanifold (three triangles on one
//       edge), torus (a torus grid with one triangle removed: one boundary loop, genus 1, not a disk),
//       closed (a tetrahedron: no boundary), annulus (two boundary loops). Boundary: a square.
//   node make_request.js polygon BOUNDARY N
//       A classify body {"polygon": ...} with the same boundary shapes, N vertices; also coil (a strip wound
//       3 turns over itself) and loop2 (a double loop around two hubs: the costly case of the classify table).
//   node make_request.js hostile KIND N
//       Small bodies that once cost the service far more than their size (tests/http/budget.bats):
//         dupfaces  a 5-vertex pyramid with N extra copies of one face (a quadratic duplicate check took minutes)
//         density   a 20 x 20 grid on the spiral asking for N times its triangles (options.target_density)
//         scale     the 8 x 8 grid's spiral boundary scaled by 10^N (N may be negative)
//         gltfcount a glTF document (model/gltf+json) whose POSITION and TEXCOORD_0 accessors have count N and
//                   no bufferView (zero-filled by the reader: N vertices from a few hundred bytes)
// The body is written to standard output as one line of JSON.
"use strict";

const fs = require("fs");

function grid(n, zMode) {
  const vertices = [];
  const faces = [];
  for (let j = 0; j < n; j++)
    for (let i = 0; i < n; i++) {
      const x = i / (n - 1), y = j / (n - 1);
      const z = zMode === "flat" ? 0 : 0.25 * Math.sin(Math.PI * x) * Math.sin(Math.PI * y);
      vertices.push([x, y, z]);
    }
  const v = (i, j) => j * n + i;
  for (let j = 0; j + 1 < n; j++)
    for (let i = 0; i + 1 < n; i++) {
      // alternate the diagonal so that the mesh is not biased in one direction
      if ((i + j) % 2 === 0) {
        faces.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
        faces.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
      } else {
        faces.push([v(i, j), v(i + 1, j), v(i, j + 1)]);
        faces.push([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
      }
    }
  return { vertices, faces };
}

// The boundary loop of a triangle mesh with one boundary: directed edges whose twin is missing, chained,
// interior on the left (the faces' orientation), starting at the lowest vertex index.
function boundaryLoop(faces) {
  const directed = new Set();
  for (const f of faces) for (let c = 0; c < 3; c++) directed.add(f[c] + "," + f[(c + 1) % 3]);
  const next = new Map();
  for (const f of faces)
    for (let c = 0; c < 3; c++) {
      const a = f[c], b = f[(c + 1) % 3];
      if (!directed.has(b + "," + a)) next.set(a, b);
    }
  if (next.size === 0) throw new Error("closed mesh: no boundary");
  const start = Math.min(...next.keys());
  const loop = [start];
  for (let v = next.get(start); v !== start; v = next.get(v)) {
    if (v === undefined || loop.length > next.size) throw new Error("boundary is not one loop");
    loop.push(v);
  }
  if (loop.length !== next.size) throw new Error("more than one boundary loop");
  return loop;
}

function positionsFor(kind, loop, vertices) {
  const n = loop.length;
  switch (kind) {
    case "square":
      return loop.map((v) => [2 * vertices[v][0], 2 * vertices[v][1]]);
    case "circle":
      return loop.map((_, k) => [Math.cos((2 * Math.PI * k) / n), Math.sin((2 * Math.PI * k) / n)]);
    case "spiral":
      return loop.map((v) => {
        const [x, y] = vertices[v];
        const r = 2 - y, a = 2.5 * Math.PI * x;
        return [r * Math.cos(a), r * Math.sin(a)];
      });
    case "clockwise":
      return loop.map((v) => [2 * vertices[v][0], -2 * vertices[v][1]]);
    case "figure8":
      return loop.map((_, k) => {
        const t = (2 * Math.PI * k) / n;
        return [Math.sin(2 * t), Math.sin(t)];
      });
    default:
      throw new Error("unknown boundary " + kind);
  }
}

function polygon(kind, n) {
  const circle = [...Array(n).keys()].map((k) => [Math.cos((2 * Math.PI * k) / n), Math.sin((2 * Math.PI * k) / n)]);
  switch (kind) {
    case "circle":
      return circle;
    case "clockwise":
      return circle.map(([x, y]) => [x, -y]);
    case "figure8":
      return [...Array(n).keys()].map((k) => {
        const t = (2 * Math.PI * k) / n;
        return [Math.sin(2 * t), Math.sin(t)];
      });
    case "spiral": {
      // an annulus sector wound 1.25 turns: outer arc out, inner arc back
      const m = Math.max(2, Math.floor(n / 2));
      const out = [];
      for (let k = 0; k < m; k++) { const a = (2.5 * Math.PI * k) / (m - 1); out.push([2 * Math.cos(a), 2 * Math.sin(a)]); }
      for (let k = m - 1; k >= 0; k--) { const a = (2.5 * Math.PI * k) / (m - 1); out.push([Math.cos(a), Math.sin(a)]); }
      return out;
    }
    case "coil": {
      // a strip wound 3 turns whose layers overlap (r = 1 + 0.15 t + rho, rho in [0, 1.6 * 0.3 pi]): heavily
      // self-overlapping, so App. C's ear reduction leaves the table most of it (as tests/support's
      // overlapping_spiral)
      const m = Math.max(2, Math.floor(n / 2));
      const w = 1.6 * 2 * Math.PI * 0.15, turns = 3;
      const at = (k, rho) => { const t = (2 * Math.PI * turns * k) / (m - 1), r = 1 + 0.15 * t + rho; return [r * Math.cos(t), r * Math.sin(t)]; };
      const out = [];
      for (let k = 0; k < m; k++) out.push(at(k, w));
      for (let k = m - 1; k >= 0; k--) out.push(at(k, 0));
      return out;
    }
    case "loop2": {
      // two hubs, then n - 2 points winding twice around them (r = 1 + 0.3 cos(t/2)): weakly self-overlapping,
      // turning number 3, and nothing for the ear reduction: the classify table at full cost (as
      // bench/bench_classify.cpp's double loop)
      const m = Math.max(3, n - 2);
      const ta = Math.PI / 2 + 0.1, tb = Math.PI / 2 + 4 * Math.PI - 0.1;
      const out = [[-0.05, 0], [0.05, 0]];
      for (let k = 0; k < m; k++) {
        const t = ta + ((tb - ta) * k) / (m - 1), r = 1 + 0.3 * Math.cos(t / 2);
        out.push([r * Math.cos(t), r * Math.sin(t)]);
      }
      return out;
    }
    default:
      throw new Error("unknown polygon " + kind);
  }
}

function invalidMesh(kind) {
  switch (kind) {
    case "nonmanifold":
      // edge (0, 1) carries three triangles
      return { vertices: [[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]],
               faces: [[0, 1, 2], [1, 0, 3], [0, 1, 4]] };
    case "closed":
      return { vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces: [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]] };
    case "torus": {
      const n = 6, m = 6, R = 2, r = 0.7;
      const vertices = [], faces = [];
      for (let j = 0; j < m; j++)
        for (let i = 0; i < n; i++) {
          const u = (2 * Math.PI * i) / n, v = (2 * Math.PI * j) / m;
          vertices.push([(R + r * Math.cos(v)) * Math.cos(u), (R + r * Math.cos(v)) * Math.sin(u), r * Math.sin(v)]);
        }
      const id = (i, j) => (j % m) * n + (i % n);
      for (let j = 0; j < m; j++)
        for (let i = 0; i < n; i++) {
          faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
          faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
      faces.pop(); // one hole: a single boundary loop of three edges
      return { vertices, faces };
    }
    case "annulus": {
      const n = 8, vertices = [], faces = [];
      for (let i = 0; i < n; i++) {
        const a = (2 * Math.PI * i) / n;
        vertices.push([Math.cos(a), Math.sin(a), 0]);
        vertices.push([2 * Math.cos(a), 2 * Math.sin(a), 0]);
      }
      for (let i = 0; i < n; i++) {
        const a = 2 * i, b = 2 * i + 1, c = (2 * i + 2) % (2 * n), d = (2 * i + 3) % (2 * n);
        faces.push([a, b, d]);
        faces.push([a, d, c]);
      }
      return { vertices, faces };
    }
    default:
      throw new Error("unknown invalid mesh " + kind);
  }
}

function hostile(kind, n) {
  switch (kind) {
    case "dupfaces": {
      const faces = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
      for (let k = 0; k < n; k++) faces.push([0, 1, 4]);
      return { mesh: { vertices: [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.25]], faces },
               boundary: { positions: [[0, 0], [2, 0], [2, 2], [0, 2]] } };
    }
    case "density":
    case "scale": {
      const mesh = grid(kind === "density" ? 20 : 8, "bump");
      const positions = positionsFor("spiral", boundaryLoop(mesh.faces), mesh.vertices);
      if (kind === "density") return { mesh, boundary: { positions }, options: { target_density: n } };
      const f = Math.pow(10, n);
      return { mesh, boundary: { positions: positions.map(([x, y]) => [x * f, y * f]) } };
    }
    case "gltfcount":
      return {
        asset: { version: "2.0" },
        scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
        meshes: [{ primitives: [{ attributes: { POSITION: 0, TEXCOORD_0: 1 }, mode: 4 }] }],
        accessors: [{ componentType: 5126, count: n, type: "VEC3", min: [0, 0, 0], max: [1, 1, 1] },
                    { componentType: 5126, count: n, type: "VEC2" }],
      };
    default:
      throw new Error("unknown hostile body " + kind);
  }
}

function readMesh(file) {
  const text = fs.readFileSync(file, "utf8");
  const vertices = [], faces = [];
  if (/\.off$/i.test(file)) {
    const tokens = text.split(/\r?\n/).map((l) => l.replace(/#.*/, "").trim()).filter((l) => l.length).join(" ").split(/\s+/);
    let p = 0;
    if (/^N?OFF$/.test(tokens[p])) p++;
    const nv = +tokens[p++], nf = +tokens[p++];
    p++;
    for (let i = 0; i < nv; i++) vertices.push([+tokens[p++], +tokens[p++], +tokens[p++]]);
    for (let i = 0; i < nf; i++) {
      const k = +tokens[p++];
      const f = [];
      for (let c = 0; c < k; c++) f.push(+tokens[p++]);
      faces.push(f);
    }
  } else {
    for (const line of text.split(/\r?\n/)) {
      const t = line.trim().split(/\s+/);
      if (t[0] === "v") vertices.push([+t[1], +t[2], +t[3]]);
      else if (t[0] === "f") faces.push(t.slice(1).map((s) => parseInt(s.split("/")[0], 10) - 1));
    }
  }
  return { vertices, faces };
}

function main(argv) {
  const [what, ...rest] = argv;
  const flag = (name) => rest.includes(name);
  const value = (name, dflt) => (rest.includes(name) ? rest[rest.indexOf(name) + 1] : dflt);
  let body;
  if (what === "grid") {
    const n = parseInt(rest[0], 10);
    const kind = rest[1] || "square";
    const mesh = grid(n, value("--z", "bump"));
    const loop = boundaryLoop(mesh.faces);
    body = { mesh, boundary: { positions: positionsFor(kind, loop, mesh.vertices) } };
  } else if (what === "mesh") {
    const mesh = readMesh(rest[0]);
    const loop = boundaryLoop(mesh.faces);
    body = { mesh, boundary: { positions: positionsFor(rest[1] || "circle", loop, mesh.vertices) } };
  } else if (what === "invalid") {
    body = { mesh: invalidMesh(rest[0]), boundary: { positions: [[0, 0], [1, 0], [1, 1], [0, 1]] } };
  } else if (what === "hostile") {
    process.stdout.write(JSON.stringify(hostile(rest[0], Number(rest[1]))) + "\n");
    return;
  } else if (what === "polygon") {
    process.stdout.write(JSON.stringify({ polygon: polygon(rest[0], parseInt(rest[1] || "16", 10)) }) + "\n");
    return;
  } else {
    console.error("usage: make_request.js grid N BOUNDARY | mesh FILE [circle] | invalid KIND | polygon BOUNDARY N | hostile KIND N");
    process.exit(2);
  }
  const options = {};
  if (value("--method")) options.method = value("--method");
  if (flag("--no-refine")) options.refine = false;
  if (Object.keys(options).length) body.options = options;
  process.stdout.write(JSON.stringify(body) + "\n");
}

module.exports = { grid, boundaryLoop, positionsFor };
if (require.main === module) main(process.argv.slice(2));
