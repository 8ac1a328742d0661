#!/usr/bin/env node
// Runs Khronos's glTF validator (npm gltf-validator, the official validator compiled to JS) on glTF files
// lipmap wrote.
//
//   node tests/tools/gltf_validate.js [--json] [--max-warnings N] FILE...
//       validates each FILE (.glb or .gltf; "-" reads standard input); prints one line per file
//       "FILE: E errors, W warnings, I infos, H hints" followed by every error (and every warning), and
//       exits 1 when any file has an error (or more than N warnings when --max-warnings is given), 2 when a
//       file cannot be read or the validator cannot even detect its format.
//       --json prints the validator's whole report for each file instead (one JSON document per line).
//
// External resources are never loaded: lipmap writes self-contained files (GLB chunk or data URIs), and a
// reference to anything else is reported by the validator as an error.
// Needs the dev dependencies of package.json (npm ci); used by tests/cli, tests/http and the C++ tests.
"use strict";

const fs = require("fs");
const validator = require("gltf-validator");

async function validateOne(file, asJson) {
  let bytes;
  try {
    bytes = file === "-" ? fs.readFileSync(0) : fs.readFileSync(file);
  } catch (e) {
    console.error(`gltf_validate: cannot read ${file}: ${e.message}`);
    return { status: 2 };
  }
  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(bytes), {
      uri: file,
      maxIssues: 0, // no limit
      externalResourceFunction: (uri) => Promise.reject(`external resource ${uri} is not loaded`),
    });
  } catch (e) {
    console.error(`gltf_validate: ${file}: the validator could not read it: ${e}`);
    return { status: 2 };
  }
  const issues = report.issues || {};
  const counts = {
    errors: issues.numErrors || 0,
    warnings: issues.numWarnings || 0,
    infos: issues.numInfos || 0,
    hints: issues.numHints || 0,
  };
  if (asJson) {
    console.log(JSON.stringify(report));
  } else {
    console.log(`${file}: ${counts.errors} errors, ${counts.warnings} warnings, ${counts.infos} infos, ${counts.hints} hints`);
    for (const m of issues.messages || []) {
      if (m.severity > 1) continue; // 0 error, 1 warning, 2 info, 3 hint
      console.log(`  ${m.severity === 0 ? "error" : "warning"} ${m.code} ${m.pointer || ""}: ${m.message}`);
    }
  }
  return { status: 0, counts };
}

async function main() {
  const args = process.argv.slice(2);
  let asJson = false;
  let maxWarnings = Infinity;
  const files = [];
  for (let i = 0; i < args.length; ++i) {
    if (args[i] === "--json") asJson = true;
    else if (args[i] === "--max-warnings") maxWarnings = Number(args[++i]);
    else files.push(args[i]);
  }
  if (files.length === 0 || !(maxWarnings >= 0)) {
    console.error("usage: node tests/tools/gltf_validate.js [--json] [--max-warnings N] FILE...");
    return 2;
  }
  let status = 0;
  for (const f of files) {
    const r = await validateOne(f, asJson);
    if (r.status !== 0) status = Math.max(status, r.status);
    else if (r.counts.errors > 0 || r.counts.warnings > maxWarnings) status = Math.max(status, 1);
  }
  return status;
}

main().then((code) => process.exit(code), (e) => {
  console.error(`gltf_validate: ${e && e.stack ? e.stack : e}`);
  process.exit(2);
});
