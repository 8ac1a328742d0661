#!/usr/bin/env node
// Drives bench/bench_cluster.sh (bench only; no assertions): asynchronous jobs against lipmap URLs.
//
//   node cluster_driver.js ab BODY PAIRS NAME_A=URL_A NAME_B=URL_B
//     PAIRS pairs of one job at a time on A and on B, interleaved (A B, then B A, ...: a slow drift of the
//     machine's load falls on both alike). Per job: POST /v1/jobs, long polls (GET ?wait=30) until final, GET the result;
//     wall time (submit to result in hand) and server time (created_at to finished_at). Prints each side's
//     medians, and the median of the paired differences B - A.
//   node cluster_driver.js throughput BODY JOBS ROUNDS NAME=URL ...
//     ROUNDS rounds; in each, every target in turn (the order rotated each round) gets JOBS jobs submitted at
//     once, then awaited one after the other (one long poll at a time, so that polling takes little CPU from
//     the workers). Jobs per second: JOBS / (first submission to last result in hand) on the client, and
//     JOBS / (first created_at to last finished_at) on the server. Prints each round and each target's medians.
// Every job must succeed (exit 1 otherwise).
"use strict";
const fs = require("fs");

const [mode, bodyFile, ...rest] = process.argv.slice(2);
const body = fs.readFileSync(bodyFile);
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const m = Math.floor(s.length / 2);
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
};
const targets = (specs) => specs.map((s) => { const i = s.indexOf("="); return { name: s.slice(0, i), url: s.slice(i + 1) }; });
const now = () => Number(process.hrtime.bigint()) / 1e6;

async function submit(url) {
  const r = await fetch(`${url}/v1/jobs`, { method: "POST", body, headers: { "Content-Type": "application/json" } });
  if (r.status !== 202) throw new Error(`POST /v1/jobs: ${r.status} ${await r.text()}`);
  return (await r.json()).id;
}
// The job's long polls (GET /v1/jobs/{id}?wait=30: answered as soon as the job ends) until it is final.
async function finish(url, id) {
  for (;;) {
    const j = await (await fetch(`${url}/v1/jobs/${id}?wait=30`)).json();
    if (j.state === "succeeded") {
      const res = await fetch(`${url}/v1/jobs/${id}/result`);
      if (res.status !== 200) throw new Error(`result: ${res.status}`);
      await res.arrayBuffer();
      return j;
    }
    if (j.state === "failed" || j.state === "cancelled") throw new Error(`job ${id} ${j.state}: ${JSON.stringify(j.error)}`);
  }
}
async function oneJob(url) {
  const t0 = now();
  const j = await finish(url, await submit(url));
  return { wall: now() - t0, server: Date.parse(j.finished_at) - Date.parse(j.created_at) };
}
const pct = (d, base) => `${d >= 0 ? "+" : ""}${d.toFixed(1)} ms (${d >= 0 ? "+" : ""}${((100 * d) / base).toFixed(1)} %)`;

async function ab(pairs, [a, b]) {
  const runs = { [a.name]: [], [b.name]: [] };
  const dWall = [], dServer = [];
  for (let i = 0; i < pairs; i++) {
    const order = i % 2 ? [b, a] : [a, b];
    const got = {};
    for (const t of order) got[t.name] = await oneJob(t.url);
    runs[a.name].push(got[a.name]);
    runs[b.name].push(got[b.name]);
    dWall.push(got[b.name].wall - got[a.name].wall);
    dServer.push(got[b.name].server - got[a.name].server);
  }
  const med = (name, k) => median(runs[name].map((r) => r[k]));
  for (const t of [a, b])
    console.log(`${t.name}: wall_ms ${med(t.name, "wall").toFixed(1)} server_ms ${med(t.name, "server").toFixed(1)} (median of ${pairs})`);
  console.log(`SUMMARY ${b.name} vs ${a.name}, ${pairs} interleaved pairs: medians wall ${pct(med(b.name, "wall") - med(a.name, "wall"), med(a.name, "wall"))}, ` +
              `server ${pct(med(b.name, "server") - med(a.name, "server"), med(a.name, "server"))}; ` +
              `median paired difference wall ${pct(median(dWall), med(a.name, "wall"))}, server ${pct(median(dServer), med(a.name, "server"))}`);
}

async function burst(url, jobs) {
  const t0 = now();
  const ids = [];
  for (let i = 0; i < jobs; i++) ids.push(await submit(url));
  let first = Infinity, last = -Infinity;
  for (const id of ids) {
    const j = await finish(url, id);
    first = Math.min(first, Date.parse(j.created_at));
    last = Math.max(last, Date.parse(j.finished_at));
  }
  return { client: (jobs * 1000) / (now() - t0), server: (jobs * 1000) / (last - first) };
}

async function throughput(jobs, rounds, ts) {
  for (const t of ts) await burst(t.url, Math.min(jobs, 4));  // warm-up
  const got = Object.fromEntries(ts.map((t) => [t.name, []]));
  for (let r = 0; r < rounds; r++) {
    const order = ts.map((_, i) => ts[(i + r) % ts.length]);
    const line = [];
    for (const t of order) {
      const x = await burst(t.url, jobs);
      got[t.name].push(x);
      line.push(`${t.name} ${x.client.toFixed(2)}/${x.server.toFixed(2)}`);
    }
    console.log(`round ${r + 1} (jobs/s client/server): ${line.join(", ")}`);
  }
  const med = (name, k) => median(got[name].map((x) => x[k]));
  for (const t of ts)
    console.log(`${t.name}: jobs_per_second client ${med(t.name, "client").toFixed(2)} server ${med(t.name, "server").toFixed(2)} (median of ${rounds} rounds of ${jobs} jobs)`);
  if (ts.length >= 2) {
    const [one, two] = ts.slice(-2);
    const paired = got[two.name].map((x, i) => x.server / got[one.name][i].server);
    console.log(`SUMMARY ${two.name} / ${one.name}: ${(med(two.name, "client") / med(one.name, "client")).toFixed(2)}x client, ` +
                `${(med(two.name, "server") / med(one.name, "server")).toFixed(2)}x server (medians); median of the rounds' ratios ` +
                `${median(paired).toFixed(2)}x server`);
  }
}

(async () => {
  if (mode === "ab") await ab(Number(rest[0]), targets(rest.slice(1, 3)));
  else if (mode === "throughput") await throughput(Number(rest[0]), Number(rest[1]), targets(rest.slice(2)));
  else throw new Error(`unknown mode ${mode}`);
})().catch((e) => { console.error(`cluster_driver: ${e.message}`); process.exit(1); });
