#!/usr/bin/env bash
# Installs every Debian package lipmap needs to build, run and test (docs/build.md).
# Idempotent: when everything is already present it does nothing and takes well under a second.
#   bash scripts/setup.sh [--with-tests] [--with-bench] [--with-fuzz]
set -euo pipefail

build_packages=(
  build-essential cmake pkg-config ccache
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libeigen3-dev libopenmesh-dev libsuitesparse-dev libopenblas0-pthread
  nlohmann-json3-dev libcpp-httplib-dev libtinygltf-dev
  libtbb-dev libspdlog-dev libcli11-dev libhiredis-dev libsimdjson-dev
)
# redis-server and nginx: the cluster suite (tests/cluster) runs them unprivileged on loopback.
test_packages=(googletest libgtest-dev libgmock-dev bats curl jq redis-server nginx)
bench_packages=(curl jq wrk bc iproute2)  # bench/bench_http.sh: wrk on loopback; bc, ss for its figures
fuzz_packages=(clang-14 libclang-rt-14-dev)  # tests/fuzz/run.sh: libFuzzer and the sanitizer runtimes

want=("${build_packages[@]}")
for arg in "$@"; do
  case "$arg" in
    --with-tests) want+=("${test_packages[@]}") ;;
    --with-bench) want+=("${bench_packages[@]}") ;;
    --with-fuzz) want+=("${fuzz_packages[@]}") ;;
    *) echo "setup: unknown option $arg (expected --with-tests, --with-bench, --with-fuzz)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${want[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then exit 0; fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
echo "setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
# Daemons are not started by the install (redis-server and nginx would take ports 6379 and 80 as system
# services; the tests start their own): a policy-rc.d that forbids starting, only for this install.
policy=/usr/sbin/policy-rc.d
own_policy=""
if [[ ! -e $policy ]]; then
  printf '#!/bin/sh\nexit 101\n' | $sudo tee "$policy" >/dev/null && $sudo chmod +x "$policy" && own_policy=1
fi
status=0
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null || status=$?
if [[ -n $own_policy ]]; then $sudo rm -f "$policy"; fi
exit "$status"
