#!/usr/bin/env node
// node check_manifests.mjs ROOT SERVE_HELP_FILE: checks the deployment files of docker/.
//  1. Every Kubernetes object of docker/k8s/*.yaml is valid against the Kubernetes OpenAPI schema
//     (kubernetes-models' validate(): types, required members, enums; it does not refuse unknown members).
//  2. The fields docs/cluster.md promises, checked one by one: readiness on /readyz, liveness on /healthz, a preStop
//     hook, terminationGracePeriodSeconds > LIPMAP_GRACE (+ the preStop pause), requests and limits,
//     non-root, read-only root filesystem; the Service and the HPA point at the Deployment; Redis is there
//     and the ConfigMap's queue URL names its Service.
//  3. docker/compose.yaml: Redis, three lipmap replicas on the shared queue, nginx in front; its nginx
//     config names the three replicas; stop_grace_period > LIPMAP_GRACE.
//  4. Every LIPMAP_* variable set anywhere is one that `lipmap serve --help` lists.
// Prints "ok N - ..." / "not ok N - ..." lines (TAP) and exits 1 when any check fails.
import fs from "node:fs";
import path from "node:path";
import { parseAllDocuments, parse } from "yaml";

const [root, helpFile] = process.argv.slice(2);
const help = fs.readFileSync(helpFile, "utf8");
let n = 0, failed = 0;
function check(name, ok, detail = "") {
  n++;
  if (ok) console.log(`ok ${n} - ${name}`);
  else {
    failed++;
    console.log(`not ok ${n} - ${name}${detail ? ": " + detail : ""}`);
  }
}

// ---- Kubernetes --------------------------------------------------------------------------------------------
const k8sDir = path.join(root, "docker/k8s");
const objects = [];
for (const file of fs.readdirSync(k8sDir).filter((f) => f.endsWith(".yaml")).sort()) {
  const docs = parseAllDocuments(fs.readFileSync(path.join(k8sDir, file), "utf8"));
  for (const doc of docs) {
    check(`${file}: YAML parses`, doc.errors.length === 0, doc.errors.map((e) => e.message).join("; "));
    const o = doc.toJS();
    if (!o) continue;
    if (o.kind === "Kustomization") {
      for (const r of o.resources ?? []) check(`${file}: resource ${r} exists`, fs.existsSync(path.join(k8sDir, r)));
      continue;
    }
    objects.push({ file, o });
  }
}
for (const { file, o } of objects) {
  const group = o.apiVersion; // "v1", "apps/v1", "autoscaling/v2"
  let model;
  try {
    model = (await import(`kubernetes-models/${group}/${o.kind}`))[o.kind];
  } catch (e) {
    check(`${file}: ${o.apiVersion} ${o.kind} is a known kind`, false, e.message);
    continue;
  }
  let error = "";
  try {
    new model(o).validate();
  } catch (e) {
    error = e.message;
  }
  check(`${file}: ${o.kind} ${o.metadata?.name} is valid against the Kubernetes schema`, error === "", error);
}
const find = (kind, name) => objects.map((x) => x.o).find((o) => o.kind === kind && (!name || o.metadata?.name === name));
const deployment = find("Deployment", "lipmap");
const configMap = find("ConfigMap", "lipmap");
check("a Deployment named lipmap", !!deployment);
check("a ConfigMap named lipmap", !!configMap);
if (deployment && configMap) {
  const pod = deployment.spec.template.spec;
  const c = pod.containers.find((x) => x.name === "lipmap") ?? pod.containers[0];
  const env = configMap.data;
  check("the container takes its settings from the ConfigMap",
        (c.envFrom ?? []).some((e) => e.configMapRef?.name === configMap.metadata.name));
  check("readiness probe on /readyz", c.readinessProbe?.httpGet?.path === "/readyz");
  check("liveness probe on /healthz", c.livenessProbe?.httpGet?.path === "/healthz");
  check("a preStop hook", !!(c.lifecycle?.preStop?.exec || c.lifecycle?.preStop?.httpGet || c.lifecycle?.preStop?.sleep));
  const preStopSeconds = Number((c.lifecycle?.preStop?.exec?.command ?? []).find((x) => /^\d+$/.test(x)) ?? 0);
  const grace = Number(env.LIPMAP_GRACE);
  check("terminationGracePeriodSeconds > LIPMAP_GRACE + the preStop pause",
        Number.isFinite(grace) && pod.terminationGracePeriodSeconds > grace + preStopSeconds,
        `${pod.terminationGracePeriodSeconds} vs ${grace} + ${preStopSeconds}`);
  check("cpu and memory requests and limits",
        ["requests", "limits"].every((k) => c.resources?.[k]?.cpu && c.resources?.[k]?.memory));
  const podSc = pod.securityContext ?? {}, sc = c.securityContext ?? {};
  check("runs as non-root", (sc.runAsNonRoot ?? podSc.runAsNonRoot) === true && (sc.runAsUser ?? podSc.runAsUser) !== 0);
  check("read-only root filesystem", sc.readOnlyRootFilesystem === true);
  check("no privilege escalation", sc.allowPrivilegeEscalation === false);
  check("a writable /tmp (emptyDir)", (c.volumeMounts ?? []).some((m) => m.mountPath === "/tmp"));
  const labels = deployment.spec.template.metadata.labels;
  const matches = (sel) => sel && Object.entries(sel).every(([k, v]) => labels[k] === v);
  check("the Deployment's selector matches its pods", matches(deployment.spec.selector.matchLabels));
  const service = find("Service", "lipmap");
  check("a Service selects the lipmap pods", !!service && matches(service.spec.selector));
  const hpa = find("HorizontalPodAutoscaler");
  check("the HPA scales the Deployment",
        !!hpa && hpa.spec.scaleTargetRef.kind === "Deployment" && hpa.spec.scaleTargetRef.name === deployment.metadata.name &&
        hpa.spec.minReplicas >= 2 && hpa.spec.maxReplicas >= hpa.spec.minReplicas);
  check("the Deployment starts with the HPA's minimum", !hpa || deployment.spec.replicas >= hpa.spec.minReplicas);
  const url = env.LIPMAP_QUEUE_URL ?? "";
  const m = /^redis:\/\/([^:/]+)(?::(\d+))?/.exec(url);
  const redisService = m && find("Service", m[1]);
  check("LIPMAP_QUEUE_URL names the Redis Service", !!redisService, url);
  const redisPods = objects.map((x) => x.o).filter((o) => ["StatefulSet", "Deployment"].includes(o.kind) &&
    o.spec.template.spec.containers.some((x) => /redis/.test(x.image)));
  check("a Redis workload behind that Service", !!redisService && redisPods.some((o) =>
    Object.entries(redisService.spec.selector).every(([k, v]) => o.spec.template.metadata.labels[k] === v)));
  for (const key of Object.keys(env))
    check(`ConfigMap ${key} is a setting of lipmap serve`, help.includes(`LIPMAP_${key.replace(/^LIPMAP_/, "")}`) && key.startsWith("LIPMAP_"));
}

// ---- compose ----------------------------------------------------------------------------------------------
const compose = parse(fs.readFileSync(path.join(root, "docker/compose.yaml"), "utf8"));
const services = compose.services ?? {};
const replicas = Object.entries(services).filter(([, s]) => s.environment?.LIPMAP_QUEUE_URL);
check("compose: three lipmap replicas on the shared queue", replicas.length === 3, `${replicas.length}`);
check("compose: a Redis service", Object.values(services).some((s) => /redis/.test(s.image ?? "")));
const nginx = Object.values(services).find((s) => /nginx/.test(s.image ?? ""));
check("compose: nginx in front, publishing a port", !!nginx && (nginx.ports ?? []).length > 0);
const nginxConf = fs.readFileSync(path.join(root, "docker/nginx.conf"), "utf8");
for (const [name] of replicas) check(`compose: nginx.conf sends to ${name}`, new RegExp(`server\\s+${name}:8080`).test(nginxConf));
for (const [name, s] of replicas) {
  const grace = Number(s.environment.LIPMAP_GRACE);
  check(`compose: ${name} stop_grace_period > LIPMAP_GRACE`, parseInt(s.stop_grace_period) > grace, `${s.stop_grace_period}`);
  check(`compose: ${name} has a read-only root filesystem`, s.read_only === true);
  const host = /^redis:\/\/([^:/]+)/.exec(s.environment.LIPMAP_QUEUE_URL)?.[1];
  check(`compose: ${name}'s queue URL names a service`, !!services[host], s.environment.LIPMAP_QUEUE_URL);
  for (const key of Object.keys(s.environment))
    check(`compose: ${name} ${key} is a setting of lipmap serve`, key.startsWith("LIPMAP_") && help.includes(key));
}
console.log(`1..${n}`);
process.exit(failed ? 1 : 0);
