#!/usr/bin/env node
// Drives bench/bench_cluster.sh (bench only): asynchronous jobs against a lipmap URL.
//   node cluster_driver.js latency URL BODY RUNS   one job at a time: POST /v1/jobs, poll every 2 ms until it is
//                                                  final, GET its result; prints the median client time (ms)
//                                                  and the median server time (created_at -> finished_at)
//   node cluster_driver.js throughput URL BODY N   N jobs submitted at once (URL may be a list, comma-separated:
//                                                  round robin), awaited one after the other (one poll at a
//                                                  time, so that polling takes little CPU); prints jobs per second from the
//                                                  first submission to the last result
// Every job must succeed (exit 1 otherwise).
"use strict";
const fs = require("fs");

const [mode, urls, bodyFile, count] = process.argv.slice(2);
const targets = urls.split(",");
const body = fs.readFileSync(bodyFile);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s[Math.floor(s.length / 2)]; };

async function submit(url) {
  const r = await fetch(`${url}/v1/jobs`, { method: "POST", body, headers: { "Content-Type": "application/json" } });
  if (r.status !== 202) throw new Error(`POST /v1/jobs: ${r.status} ${await r.text()}`);
  return (await r.json()).id;
}
async function finish(url, id, pollMs) {
  for (;;) {
    const r = await fetch(`${url}/v1/jobs/${id}`);
    const j = await r.json();
    if (j.state === "succeeded") {
      const res = await fetch(`${url}/v1/jobs/${id}/result`);
      if (res.status !== 200) throw new Error(`result: ${res.status}`);
      await res.arrayBuffer();
      return j;
    }
    if (j.state === "failed" || j.state === "cancelled") throw new Error(`job ${id} ${j.state}: ${JSON.stringify(j.error)}`);
    await sleep(pollMs);
  }
}

(async () => {
  const n = Number(count);
  if (mode === "latency") {
    const client = [], server = [];
    for (let i = 0; i < n; i++) {
      const t0 = process.hrtime.bigint();
      const id = await submit(targets[0]);
      const j = await finish(targets[0], id, 2);
      client.push(Number(process.hrtime.bigint() - t0) / 1e6);
      server.push(Date.parse(j.finished_at) - Date.parse(j.created_at));
    }
    console.log(`client_ms ${median(client).toFixed(1)} server_ms ${median(server).toFixed(1)}`);
  } else {
    const t0 = process.hrtime.bigint();
    const ids = [];
    for (let i = 0; i < n; i++) ids.push([targets[i % targets.length], await submit(targets[i % targets.length])]);
    // One poll at a time, in submission order: polls of 60 jobs at once would take the cores from the workers.
    for (const [u, id] of ids) await finish(u, id, 5);
    const s = Number(process.hrtime.bigint() - t0) / 1e9;
    console.log(`jobs_per_second ${(n / s).toFixed(2)} seconds ${s.toFixed(2)}`);
  }
})().catch((e) => { console.error(`cluster_driver: ${e.message}`); process.exit(1); });
