#!/usr/bin/env node
// Validates lipmap's JSON against the schemas in proto/ (JSON Schema draft 2020-12, with ajv).
//
//   node tests/tools/validate_json.js SCHEMA [FILE|-]
//       validate one document (default: standard input) against proto/SCHEMA (e.g. classify-answer.schema.json);
//       prints the errors and exits 1 when it does not validate
//   node tests/tools/validate_json.js --check
//       compile every proto/*.schema.json in strict mode, validate each schema's own "examples" against it,
//       and check that every "$ref" of proto/openapi.json resolves; exits 1 on any failure
//
// Needs the dev dependencies of package.json (npm ci); used by tests/cli and tests/http.
"use strict";

const fs = require("fs");
const path = require("path");
const Ajv2020 = require("ajv/dist/2020").default;
const addFormats = require("ajv-formats").default;

const protoDir = path.resolve(__dirname, "..", "..", "proto");

function loadAjv() {
  const ajv = new Ajv2020({ strict: true, allErrors: true });
  addFormats(ajv);
  for (const name of fs.readdirSync(protoDir).filter((n) => n.endsWith(".schema.json")).sort()) {
    const schema = JSON.parse(fs.readFileSync(path.join(protoDir, name), "utf8"));
    ajv.addSchema(schema, name); // no $id: each schema is known by its file name, as relative $refs name it
  }
  return ajv;
}

function describe(errors) {
  return errors.map((e) => `  ${e.instancePath || "(root)"} ${e.message} ${JSON.stringify(e.params)}`).join("\n");
}

function validateOne(schemaName, file) {
  const ajv = loadAjv();
  const validate = ajv.getSchema(schemaName);
  if (!validate) {
    console.error(`validate_json: no schema ${schemaName} in ${protoDir}`);
    return 2;
  }
  const text = fs.readFileSync(file === "-" ? 0 : file, "utf8");
  let doc;
  try {
    doc = JSON.parse(text);
  } catch (e) {
    console.error(`validate_json: ${file} is not JSON: ${e.message}`);
    return 1;
  }
  if (!validate(doc)) {
    console.error(`validate_json: ${file} does not validate against ${schemaName}:\n${describe(validate.errors)}`);
    return 1;
  }
  return 0;
}

// Resolves "file.json#/json/pointer" or "#/pointer" relative to proto/.
function resolveRef(ref, currentFile) {
  const [file, fragment = ""] = ref.split("#");
  const target = file ? path.join(protoDir, file) : currentFile;
  if (!fs.existsSync(target)) return `file ${file} does not exist`;
  let node = JSON.parse(fs.readFileSync(target, "utf8"));
  for (const token of fragment.split("/").slice(1)) {
    const key = token.replace(/~1/g, "/").replace(/~0/g, "~");
    if (node === null || typeof node !== "object" || !(key in node)) return `pointer #${fragment} not found in ${path.basename(target)}`;
    node = node[key];
  }
  return null;
}

function collectRefs(node, out) {
  if (Array.isArray(node)) node.forEach((n) => collectRefs(n, out));
  else if (node && typeof node === "object") {
    for (const [k, v] of Object.entries(node)) {
      if (k === "$ref" && typeof v === "string") out.push(v);
      else collectRefs(v, out);
    }
  }
  return out;
}

function check() {
  let failures = 0;
  let ajv;
  try {
    ajv = loadAjv();
  } catch (e) {
    console.error(`validate_json: the schemas do not compile: ${e.message}`);
    return 1;
  }
  const names = fs.readdirSync(protoDir).filter((n) => n.endsWith(".schema.json")).sort();
  for (const name of names) {
    let validate;
    try {
      validate = ajv.getSchema(name);
    } catch (e) {
      console.error(`validate_json: ${name} does not compile: ${e.message}`);
      failures++;
      continue;
    }
    const schema = JSON.parse(fs.readFileSync(path.join(protoDir, name), "utf8"));
    for (const [i, example] of (schema.examples || []).entries()) {
      if (!validate(example)) {
        console.error(`validate_json: ${name} example ${i} does not validate:\n${describe(validate.errors)}`);
        failures++;
      }
    }
    for (const ref of collectRefs(schema, [])) {
      const problem = resolveRef(ref, path.join(protoDir, name));
      if (problem) {
        console.error(`validate_json: ${name}: $ref ${ref}: ${problem}`);
        failures++;
      }
    }
  }
  const openapiFile = path.join(protoDir, "openapi.json");
  const openapi = JSON.parse(fs.readFileSync(openapiFile, "utf8"));
  if (!/^3\.1\.\d+$/.test(openapi.openapi || "")) {
    console.error(`validate_json: openapi.json is not OpenAPI 3.1 (openapi: ${openapi.openapi})`);
    failures++;
  }
  for (const ref of collectRefs(openapi, [])) {
    const problem = resolveRef(ref, openapiFile);
    if (problem) {
      console.error(`validate_json: openapi.json: $ref ${ref}: ${problem}`);
      failures++;
    }
  }
  for (const [p, item] of Object.entries(openapi.paths || {})) {
    for (const [method, op] of Object.entries(item)) {
      if (method === "parameters") continue;
      if (!op.responses || Object.keys(op.responses).length === 0) {
        console.error(`validate_json: openapi.json: ${method.toUpperCase()} ${p} has no responses`);
        failures++;
      }
    }
  }
  if (failures === 0) console.log(`validate_json: ${names.length} schemas and openapi.json are consistent`);
  return failures ? 1 : 0;
}

const args = process.argv.slice(2);
if (args[0] === "--check") process.exit(check());
if (args.length < 1 || args.length > 2) {
  console.error("usage: validate_json.js SCHEMA [FILE|-] | --check");
  process.exit(2);
}
process.exit(validateOne(args[0], args[1] || "-"));
