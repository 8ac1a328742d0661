#!/usr/bin/env node
// Drives bench/bench_overload.sh (bench only): POSTs one body to a lipmap URL and prints one line per answer,
// "STATUS MS RETRY_AFTER" (status 000 when no answer came within 30 s or the connection failed; RETRY_AFTER
// "-" when absent).
//   node overload_driver.js closed URL BODY N SECONDS   N clients, each sending again as soon as it has a 200
//                                                       (10 ms after any other answer)
//   node overload_driver.js open URL BODY RATE SECONDS  RATE requests per second whatever the answers (an open
//                                                       loop: the offered load does not drop when the service
//                                                       slows down, as it would with closed-loop clients)
// One node process instead of a curl per request: on 2 cores, starting hundreds of processes a second would
// take the CPU from the service it measures. Requests are sent with keep-alive; a refusal closes its connection
// (the service never reads the body of a refused request), and the next one opens another.
"use strict";
const fs = require("fs");
const http = require("http");

const [mode, url, bodyFile, amount, seconds] = process.argv.slice(2);
const body = fs.readFileSync(bodyFile);
const target = new URL(url);
const agent = new http.Agent({ keepAlive: true, maxSockets: Infinity });
const lines = [];
let outstanding = 0;
// An open loop must not open sockets without bound when the service stalls: beyond this many requests in
// flight a request is not sent, and counted as "drop" (none is expected: the service answers at once when full).
const maxOutstanding = 2000;
let dropped = 0;

function post() {
  return new Promise((resolve) => {
    const t0 = process.hrtime.bigint();
    let done = false;
    const finish = (status, retry) => {
      if (done) return;
      done = true;
      outstanding--;
      const ms = Number(process.hrtime.bigint() - t0) / 1e6;
      lines.push(`${status} ${ms.toFixed(2)} ${retry === undefined ? "-" : retry}`);
      resolve(status);
    };
    outstanding++;
    const req = http.request(
      { host: target.hostname, port: target.port, path: "/v1/parametrize", method: "POST", agent,
        headers: { "Content-Type": "application/json", "Content-Length": body.length } },
      (res) => {
        res.on("data", () => {});
        res.on("end", () => finish(res.statusCode, res.headers["retry-after"]));
        res.on("error", () => finish("000"));
      });
    req.setTimeout(30000, () => { req.destroy(); finish("000"); });
    // A refusal may close the connection before the whole body is written: the answer still counts.
    req.on("error", () => finish("000"));
    req.end(body);
  });
}

const n = Number(amount), until = Date.now() + Number(seconds) * 1000;
(async () => {
  if (mode === "closed") {
    // A 503 here means a slot was not yet free (a worker counts its task until just after the answer is
    // out): a client retrying at once on its kept-alive connection would spin and take CPU from the workers.
    const loop = async () => {
      while (Date.now() < until) {
        if ((await post()) !== 200) await new Promise((r) => setTimeout(r, 10));
      }
    };
    await Promise.all(Array.from({ length: n }, loop));
  } else if (mode === "open") {
    const start = Date.now();
    let sent = 0;
    await new Promise((resolve) => {
      const tick = setInterval(() => {
        const now = Date.now();
        const due = Math.floor(((Math.min(now, until) - start) / 1000) * n);
        for (; sent < due; sent++) {
          if (outstanding >= maxOutstanding) { dropped++; continue; }
          post();
        }
        if (now >= until) { clearInterval(tick); resolve(); }
      }, 2);
    });
    while (outstanding > 0) await new Promise((r) => setTimeout(r, 20));
  } else {
    console.error("usage: overload_driver.js closed|open URL BODY N|RATE SECONDS");
    process.exit(2);
  }
  agent.destroy();
  process.stdout.write(lines.join("\n") + (lines.length ? "\n" : ""));
  if (dropped) console.error(`overload_driver: ${dropped} requests not sent (${maxOutstanding} in flight)`);
})();
