#!/usr/bin/env bash
# Builds the libFuzzer targets (clang++-14, ASan + UBSan, in build-fuzz) and runs each for SECONDS (default
# 60) on a scratch copy of its seed corpus (tests/fuzz/corpus/TARGET; the committed corpus is never written).
# One line per target: "fuzz: TARGET: N execs, E execs/s, C crashes". Exits non-zero when any target
# crashed, leaked, timed out, ran out of memory, hit a sanitizer report or let an unexpected exception
# escape; the reproducer (crash-*, leak-*, timeout-*, oom-*) and the log are kept and their paths printed.
#   bash tests/fuzz/run.sh [SECONDS]        e.g. bash tests/fuzz/run.sh 600 for a long run
# Scratch files of the targets go under the run folder (TMPDIR). LIPMAP_FUZZ_BUILD_DIR (default build-fuzz),
# LIPMAP_JOBS (default 2), LIPMAP_FUZZ_TARGETS (default all), LIPMAP_FUZZ_RUNS (inputs per target, seeded).
set -uo pipefail

seconds=${1:-60}
if ! [[ $seconds =~ ^[0-9]+$ ]] || ((seconds == 0)); then
  echo "usage: bash tests/fuzz/run.sh [SECONDS]" >&2
  exit 2
fi
cd "$(dirname "$0")/../.." || exit 2
root=$PWD
build=${LIPMAP_FUZZ_BUILD_DIR:-build-fuzz}
jobs=${LIPMAP_JOBS:-2}
targets=(${LIPMAP_FUZZ_TARGETS:-fuzz_json_request fuzz_gltf_read fuzz_mesh_file fuzz_classify})
export CCACHE_BASEDIR=$root

if ! command -v clang++-14 >/dev/null; then
  echo "fuzz: clang++-14 not found (bash scripts/setup.sh --with-fuzz)" >&2
  exit 2
fi
mkdir -p "$build"
# -O1 with line tables, as libFuzzer's documentation builds its targets: a cold -O3 build of the engine under
# the sanitizers costs a CI run on 2 cores many minutes more.
cmake -S . -B "$build" -DLIPMAP_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_FLAGS_RELEASE="-O1 -g1 -DNDEBUG" -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >"$build/fuzz-configure.log" 2>&1 \
  || { cat "$build/fuzz-configure.log" >&2; echo "fuzz: configure failed" >&2; exit 2; }
cmake --build "$build" -j"$jobs" --target "${targets[@]}" >"$build/fuzz-build.log" 2>&1 \
  || { tail -50 "$build/fuzz-build.log" >&2; echo "fuzz: build failed" >&2; exit 2; }

# LIPMAP_FUZZ_RUNS=N (CI): N inputs per target from a fixed seed instead of a time budget, so that a run does
# the same work on every machine.
if [[ -n "${LIPMAP_FUZZ_RUNS:-}" ]]; then
  budget=(-runs="$LIPMAP_FUZZ_RUNS" -seed=1)
  what="$LIPMAP_FUZZ_RUNS inputs (seed 1)"
else
  budget=(-max_total_time="$seconds")
  what="$seconds s"
fi
out=$(mktemp -d "${TMPDIR:-/tmp}/lipmap-fuzz.XXXXXX")
# Sanitizer reports end the run (libFuzzer then writes the reproducer); leaks are checked at every input.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=0
for target in "${targets[@]}"; do
  corpus=$out/$target.corpus
  mkdir -p "$corpus" "$out/$target.artifacts"
  cp -r "tests/fuzz/corpus/$target/." "$corpus/"
  log=$out/$target.log
  TMPDIR=$out "$build/tests/fuzz/$target" "$corpus" "${budget[@]}" -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$out/$target.artifacts/" >"$log" 2>&1
  rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  artifacts=$(find "$out/$target.artifacts" -type f | wc -l)
  # A sanitizer report or an escaped exception that did not produce an artifact still counts.
  if ((rc != 0)) && ((artifacts == 0)); then artifacts=1; fi
  if grep -qE '^SUMMARY: (Address|Undefined|Leak)Sanitizer|runtime error:' "$log" && ((artifacts == 0)); then
    artifacts=1
  fi
  echo "fuzz: $target: ${execs:-0} execs, ${rate:-0} execs/s, $artifacts crashes"
  if ((artifacts > 0)); then
    failed=1
    echo "fuzz: $target: exit $rc, log $log" >&2
    find "$out/$target.artifacts" -type f -printf 'fuzz: %p\n' >&2
    grep -m1 -E '==ERROR|runtime error:|deadly signal|terminate called|Sanitizer' "$log" >&2
  else
    rm -rf "$corpus"
  fi
done
if ((failed)); then
  echo "fuzz: FAILED (kept in $out)" >&2
  exit 1
fi
rm -rf "$out"
echo "fuzz: ${#targets[@]} targets, $what each, 0 crashes"
