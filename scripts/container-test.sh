#!/usr/bin/env bash
# The image test (README "Containers"): builds docker/Dockerfile, starts the image, checks GET /healthz and one
# POST /v1/parametrize, sends SIGTERM and expects the service to drain and exit 0. Also checks that it runs as
# a non-root user on a read-only root filesystem (as docker/k8s/deployment.yaml runs it).
#
#   bash scripts/container-test.sh
#
# Two paths, chosen by what works here:
#   docker   a docker daemon answers (`docker info`): `docker build`, `docker run -p 127.0.0.1:PORT:8080`.
#   podman   otherwise, as root: podman with the runc runtime and the cgroupfs manager (crun refuses hybrid
#            cgroup setups), host networking, and rlimits no higher than the machine's. When the base images
#            (debian:12, debian:12-slim) cannot be pulled (no registry reachable), they are made from the
#            Debian mirror with mmdebstrap and imported. Installs podman, runc and mmdebstrap (Debian
#            packages) when missing.
# Environment: LIPMAP_CONTAINER_ENGINE=docker|podman forces a path; LIPMAP_IMAGE (default lipmap:test).
# Takes 4 to 10 minutes on 2 cores (the image compiles lipmap: builds of 200 s to 9 min on different VMs).
# Prints the image size, the build time and the run's log; exits non-zero when anything fails.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

image="${LIPMAP_IMAGE:-lipmap:test}"
name="lipmap-container-test-$$"
work="$(mktemp -d)"
engine="${LIPMAP_CONTAINER_ENGINE:-}"
say() { echo "container-test: $*" >&2; }

if [[ -z "$engine" ]]; then
  if command -v docker >/dev/null && timeout 20 docker info >/dev/null 2>&1; then engine=docker; else engine=podman; fi
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
engine_cmd=()
build_opts=()
run_opts=()
if [[ "$engine" == docker ]]; then
  engine_cmd=(docker)
else
  missing=()
  for p in podman runc mmdebstrap; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]} > 0)); then
    say "installing ${missing[*]}"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
  engine_cmd=($sudo podman --runtime runc --cgroup-manager cgroupfs)
  # Host networking (no CNI setup needed) and rlimits that an unprivileged raise cannot exceed.
  build_opts=(--network host --ulimit nofile=1024:1024 --ulimit nproc=1024:1024)
  run_opts=(--network host --ulimit nofile=1024:1024 --ulimit nproc=1024:1024)
  # Base images: pulled when a registry answers, else made from the Debian mirror.
  for base in debian:12 debian:12-slim; do
    if ! "${engine_cmd[@]}" image exists "docker.io/library/$base" 2>/dev/null &&
       ! timeout 60 "${engine_cmd[@]}" pull -q "docker.io/library/$base" >/dev/null 2>&1; then
      if [[ ! -s "$work/bookworm.tar" ]]; then
        say "no registry: making the Debian 12 base image with mmdebstrap"
        $sudo mmdebstrap --quiet --variant=minbase bookworm "$work/bookworm.tar"
        "${engine_cmd[@]}" import -q "$work/bookworm.tar" localhost/debian:12 >/dev/null
      fi
      "${engine_cmd[@]}" tag localhost/debian:12 "docker.io/library/$base"
    fi
  done
fi

cleanup() {
  "${engine_cmd[@]}" rm -f "$name" >/dev/null 2>&1 || true
  $sudo rm -rf "$work"
}
trap cleanup EXIT

say "engine: ${engine_cmd[*]}"
t0=$(date +%s)
"${engine_cmd[@]}" build "${build_opts[@]}" -f docker/Dockerfile -t "$image" . >"$work/build.log" 2>&1 ||
  { tail -n 40 "$work/build.log" >&2; say "FAIL: the image did not build"; exit 1; }
t1=$(date +%s)
size="$("${engine_cmd[@]}" image inspect "$image" --format '{{.Size}}')"
say "image $image built in $((t1 - t0)) s; size $((size / 1000000)) MB"

port="$(node -e 'const s=require("net").createServer();s.listen(0,"127.0.0.1",()=>{console.log(s.address().port);s.close()})' 2>/dev/null ||
        echo 18080)"
if [[ "$engine" == docker ]]; then
  run_opts=(-p "127.0.0.1:$port:8080")
else
  run_opts+=(-e "LIPMAP_PORT=$port")
fi
# As Kubernetes runs it: read-only root filesystem, a tmpfs /tmp.
"${engine_cmd[@]}" run -d --name "$name" --read-only --tmpfs /tmp "${run_opts[@]}" -e LIPMAP_GRACE=10 "$image" >/dev/null
url="http://127.0.0.1:$port"
fail() {
  say "FAIL: $*"
  "${engine_cmd[@]}" logs "$name" >&2 || true
  exit 1
}
for _ in $(seq 100); do
  curl -sf --max-time 2 "$url/healthz" >/dev/null && break
  sleep 0.2
done
[[ "$(curl -sf --max-time 5 "$url/healthz")" == ok ]] || fail "GET /healthz did not answer ok"
say "GET /healthz: ok"
uid="$("${engine_cmd[@]}" exec "$name" id -u)"
[[ "$uid" != 0 ]] || fail "the service runs as root"
say "runs as uid $uid"
code="$(curl -s -o "$work/answer.json" -w '%{http_code}' --max-time 120 --json @tests/data/requests/grid8_spiral.json "$url/v1/parametrize")"
[[ "$code" == 200 ]] || fail "POST /v1/parametrize answered $code: $(head -c 400 "$work/answer.json")"
verdict="$(jq -r .verdict "$work/answer.json")"
[[ "$verdict" == self_overlapping ]] || fail "POST /v1/parametrize: verdict $verdict"
say "POST /v1/parametrize: 200, verdict $verdict, $(jq '.uv | length' "$work/answer.json") uv"
# SIGTERM (what docker stop / podman stop / Kubernetes send): drain, then exit 0.
"${engine_cmd[@]}" stop -t 30 "$name" >/dev/null
status="$("${engine_cmd[@]}" inspect "$name" --format '{{.State.ExitCode}}')"
say "run's log:"
"${engine_cmd[@]}" logs "$name" 2>&1 | sed 's/^/  /' >&2
[[ "$status" == 0 ]] || fail "exit status after SIGTERM: $status"
say "SIGTERM: exit 0"
say "PASS (build $((t1 - t0)) s, image $((size / 1000000)) MB)"
