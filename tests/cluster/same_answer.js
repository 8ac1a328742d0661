#!/usr/bin/env node
// node same_answer.js A B: exits 0 when two parametrize answers (JSON, or glTF binary) say the same thing:
// equal after dropping the wall-clock timings (every "timings_ms" member), which differ from run to run; a
// GLB's binary chunk must be byte-identical. Prints the first difference otherwise.
"use strict";
const fs = require("fs");

function strip(v) {
  if (Array.isArray(v)) return v.map(strip);
  if (v && typeof v === "object") {
    const out = {};
    for (const k of Object.keys(v).sort()) if (k !== "timings_ms") out[k] = strip(v[k]);
    return out;
  }
  return v;
}

// {json, bin} of an answer: a GLB's two chunks, or a JSON document.
function read(file) {
  const b = fs.readFileSync(file);
  if (b.length >= 12 && b.toString("latin1", 0, 4) === "glTF") {
    let at = 12, json = null, bin = Buffer.alloc(0);
    while (at + 8 <= b.length) {
      const len = b.readUInt32LE(at), type = b.readUInt32LE(at + 4);
      const data = b.subarray(at + 8, at + 8 + len);
      if (type === 0x4e4f534a) json = JSON.parse(data.toString("utf8"));
      else if (type === 0x004e4942) bin = data;
      at += 8 + len;
    }
    return { json, bin };
  }
  return { json: JSON.parse(b.toString("utf8")), bin: Buffer.alloc(0) };
}

const [a, b] = process.argv.slice(2).map(read);
const ja = JSON.stringify(strip(a.json)), jb = JSON.stringify(strip(b.json));
if (ja !== jb) {
  let i = 0;
  while (i < ja.length && ja[i] === jb[i]) i++;
  console.error(`answers differ at character ${i}: ...${ja.slice(Math.max(0, i - 60), i + 60)}... vs ...${jb.slice(Math.max(0, i - 60), i + 60)}...`);
  process.exit(1);
}
if (!a.bin.equals(b.bin)) {
  console.error("the binary chunks differ");
  process.exit(1);
}
