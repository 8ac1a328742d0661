#!/usr/bin/env bash
# The test command (README): installs what is missing (Debian packages via setup.sh, the npm test tools
# of package.json into ./node_modules), builds everything into build/ (Release, ccache; with CI=true the
# project's warnings are errors), runs the GoogleTest suite with ctest, the layout rules
# (tests/layout/check_layout.sh), then the bats suites (tests/cli, tests/http, tests/cluster); in CI (or with
# LIPMAP_SANITIZERS=1) also the unit tests and the bad-input suites under ASan and UBSan, and (LIPMAP_FUZZ=1)
# a fixed, seeded run of each fuzzer. Everything it reads is in the
# repository. Exits non-zero when anything fails; the last line sums up: "tests: N passed, M failed".
#
# Every step is bounded in time (a hung test fails its step instead of the whole run's budget), and each
# "==" line says how long the run has taken so far.
#
# Environment: LIPMAP_BUILD_DIR (default build), LIPMAP_JOBS (default 2).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root="$PWD"
build_dir="${LIPMAP_BUILD_DIR:-build}"
jobs="${LIPMAP_JOBS:-2}"
# ccache keys on paths relative to the checkout, so that every clone of the repository shares one cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
# The sanitizer build has debug info (-g), for which ccache would also key on the build folder by default.
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"

SECONDS=0
step() { printf '== %s (at %dm%02ds)\n' "$*" $((SECONDS / 60)) $((SECONDS % 60)); }
# Bounds that only catch hangs: a single GoogleTest case, a bats suite, the sanitized GoogleTest run. (Not
# bats' own BATS_TEST_TIMEOUT: its watchdog can outlive a fast test and hold the output pipe open.)
ctest_timeout=900 bats_timeout=1200 asan_timeout=2700

step setup
bash scripts/setup.sh --with-tests
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  # Test-only: the schema validator runs on Node. Debian's packages, when the machine has none.
  sudo=""
  if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
  echo "test: installing nodejs npm" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
npm ci --no-audit --no-fund --loglevel=error

step "build ($build_dir, Release)"
# CI builds with warnings as errors; a developer's build only shows them.
werror=OFF
if [[ "${CI:-}" == true ]]; then werror=ON; fi
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DLIPMAP_WERROR="$werror"
cmake --build "$build_dir" -j "$jobs"

export LIPMAP_BIN="$root/$build_dir/server/lipmap"
export LIPMAP_BUILD_DIR="$build_dir"
logs="$(mktemp -d)"
trap 'rm -rf "$logs"' EXIT
set +e
failed_steps=()
passed=0 failed=0 skipped=0

step ctest
ctest --test-dir "$build_dir" --output-on-failure --no-tests=error --timeout "$ctest_timeout" -j "$jobs" 2>&1 | tee "$logs/ctest.log"
[[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=(ctest)
# "100% tests passed, 0 tests failed out of 57"
if summary=$(grep -E '[0-9]+ tests failed out of [0-9]+' "$logs/ctest.log" | tail -n 1); then
  f=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\1/' <<<"$summary")
  t=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\2/' <<<"$summary")
  # GTEST_SKIP()ped tests: ctest counts them among the passed ones; here they are counted as skipped.
  s=$(grep -c '\*\*\*Skipped' "$logs/ctest.log" || true)
  passed=$((passed + t - f - s)) failed=$((failed + f)) skipped=$((skipped + s))
fi

step layout
bash tests/layout/check_layout.sh 2>&1 | tee "$logs/layout.log"
[[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=(layout)
p=$(grep -cE '^ok [0-9]+' "$logs/layout.log") f=$(grep -cE '^not ok [0-9]+' "$logs/layout.log")
passed=$((passed + p)) failed=$((failed + f))

run_bats() {  # run_bats STEP FILES...: one bats run, counted
  local step="$1"; shift
  step "bats $step"
  timeout --kill-after=30 "$bats_timeout" bats --tap "$@" 2>&1 | tee "$logs/bats.log"
  [[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=("bats $step")
  local s p f
  s=$(grep -cE '^ok [0-9]+ .*# skip' "$logs/bats.log")
  p=$(grep -cE '^ok [0-9]+' "$logs/bats.log")
  f=$(grep -cE '^not ok [0-9]+' "$logs/bats.log")
  passed=$((passed + p - s)) failed=$((failed + f)) skipped=$((skipped + s))
}
# tests/cluster: Redis, three replicas and nginx on loopback (about a minute), and the deployment files.
for suite in tests/cli tests/http tests/cluster; do
  compgen -G "$suite/*.bats" >/dev/null || continue
  run_bats "$suite" "$suite"
done

# Sanitizers: the unit tests (less the long mesh x target matrices) and the bad-input suites once more under
# AddressSanitizer (leaks included) and UndefinedBehaviorSanitizer, built in a folder of their own. Always in
# CI; locally with LIPMAP_SANITIZERS=1 (a second full build).
if [[ "${CI:-}" == true || "${LIPMAP_SANITIZERS:-}" == 1 ]]; then
  asan_dir="$build_dir-asan"
  step "sanitizers: build ($asan_dir, address,undefined)"
  # -O1 and line tables only (-g1): the sanitizers need neither -O2 nor full debug info, and on 2 cores a cold
  # build of every test at -O2 -g ran past 27 minutes (for 90% of it), most of a CI run's budget.
  if cmake -S . -B "$asan_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
       -DLIPMAP_SANITIZE=address,undefined -DLIPMAP_BUILD_BENCH=OFF -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null &&
     cmake --build "$asan_dir" -j "$jobs" --target lipmap lipmap_tests >"$logs/asan-build.log" 2>&1; then
    export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    step "sanitizers: GoogleTest"
    timeout --kill-after=30 "$asan_timeout" "$asan_dir/tests/lipmap_tests" --gtest_brief=1 \
      --gtest_filter='-MapPipelineTargets*:GltfPipeline*:*Shared*:Readme*:MetricReproduction*:MetricRepair*' 2>&1 | tee "$logs/asan.log"
    asan_status=${PIPESTATUS[0]}
    if ((asan_status != 0)); then
      failed_steps+=("sanitizers gtest")
      # A sanitizer's report at exit (a leak) comes after GoogleTest's summary: say what ended the run, and
      # again at the end, where a shortened log still shows it.
      {
        echo "sanitizers gtest: exit status $asan_status"
        grep -E '^\[  (PASSED|FAILED|SKIPPED) *\]|ERROR: (Address|Leak)Sanitizer|runtime error:|^SUMMARY: ' "$logs/asan.log" | head -n 20
      } | tee "$logs/asan-why.log"
    fi
    p=$(sed -nE 's/^\[  PASSED  \] ([0-9]+) tests?\.$/\1/p' "$logs/asan.log" | tail -n 1)
    f=$(sed -nE 's/^\[  FAILED  \] ([0-9]+) tests?, listed below:$/\1/p' "$logs/asan.log" | tail -n 1)
    passed=$((passed + ${p:-0})) failed=$((failed + ${f:-0}))
    export LIPMAP_BIN="$root/$asan_dir/server/lipmap"
    run_bats "sanitizers (bad input)" tests/cli tests/http/errors.bats tests/http/hardening.bats tests/http/precision.bats
    export LIPMAP_BIN="$root/$build_dir/server/lipmap"
  else
    tail -n 40 "$logs/asan-build.log"
    failed_steps+=("sanitizers build")
  fi
fi

# Fuzzers: in CI each libFuzzer target (tests/fuzz/) runs a fixed number of inputs from a fixed seed on its
# seed corpus, so that the run is the same on every machine; a crash, leak or sanitizer report fails it.
# `bash tests/fuzz/run.sh 600` is the long run.
if [[ "${CI:-}" == true || "${LIPMAP_FUZZ:-}" == 1 ]]; then
  step fuzz
  bash scripts/setup.sh --with-fuzz
  LIPMAP_FUZZ_RUNS="${LIPMAP_FUZZ_RUNS:-20000}" bash tests/fuzz/run.sh 2>&1 | tee "$logs/fuzz.log"
  [[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=(fuzz)
  p=$(grep -cE '^fuzz: [a-z_]+: .* 0 crashes$' "$logs/fuzz.log") f=$(grep -cE '^fuzz: [a-z_]+: .* [1-9][0-9]* crashes$' "$logs/fuzz.log")
  passed=$((passed + p)) failed=$((failed + f))
fi

step end
if ((${#failed_steps[@]} > 0)); then
  [[ -s "$logs/asan-why.log" ]] && cat "$logs/asan-why.log"
  echo "== FAILED: ${failed_steps[*]}"
  ((failed > 0)) || failed=1  # a step that failed without a counted test failure (a crash, a missing binary)
fi
echo "tests: $passed passed, $failed failed$( ((skipped > 0)) && echo ", $skipped skipped")"
((${#failed_steps[@]} == 0))
