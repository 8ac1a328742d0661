#!/usr/bin/env bash
# The test command (README): installs what is missing (Debian packages via setup.sh, the npm test tools
# of package.json into ./node_modules), builds everything into build/ (Release, ccache; with CI=true the
# project's warnings are errors), runs the GoogleTest suite with ctest, the layout rules
# (tests/layout/check_layout.sh), then the bats suites (tests/cli, tests/http). Everything it reads is in the
# repository. Exits non-zero when anything fails; the last line sums up: "tests: N passed, M failed".
#
# Environment: LIPMAP_BUILD_DIR (default build), LIPMAP_JOBS (default 2).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root="$PWD"
build_dir="${LIPMAP_BUILD_DIR:-build}"
jobs="${LIPMAP_JOBS:-2}"
# ccache keys on paths relative to the checkout, so that every clone of the repository shares one cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"

echo "== setup"
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

echo "== build ($build_dir, Release)"
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

echo "== ctest"
ctest --test-dir "$build_dir" --output-on-failure --no-tests=error -j "$jobs" 2>&1 | tee "$logs/ctest.log"
[[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=(ctest)
# "100% tests passed, 0 tests failed out of 57"
if summary=$(grep -E '[0-9]+ tests failed out of [0-9]+' "$logs/ctest.log" | tail -n 1); then
  f=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\1/' <<<"$summary")
  t=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\2/' <<<"$summary")
  # GTEST_SKIP()ped tests: ctest counts them among the passed ones; here they are counted as skipped.
  s=$(grep -c '\*\*\*Skipped' "$logs/ctest.log" || true)
  passed=$((passed + t - f - s)) failed=$((failed + f)) skipped=$((skipped + s))
fi

echo "== layout"
bash tests/layout/check_layout.sh 2>&1 | tee "$logs/layout.log"
[[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=(layout)
p=$(grep -cE '^ok [0-9]+' "$logs/layout.log") f=$(grep -cE '^not ok [0-9]+' "$logs/layout.log")
passed=$((passed + p)) failed=$((failed + f))

for suite in tests/cli tests/http; do
  compgen -G "$suite/*.bats" >/dev/null || continue
  echo "== bats $suite"
  bats --tap "$suite" 2>&1 | tee "$logs/bats.log"
  [[ ${PIPESTATUS[0]} -eq 0 ]] || failed_steps+=("bats $suite")
  s=$(grep -cE '^ok [0-9]+ .*# skip' "$logs/bats.log")
  p=$(grep -cE '^ok [0-9]+' "$logs/bats.log")
  f=$(grep -cE '^not ok [0-9]+' "$logs/bats.log")
  passed=$((passed + p - s)) failed=$((failed + f)) skipped=$((skipped + s))
done

if ((${#failed_steps[@]} > 0)); then
  echo "== FAILED: ${failed_steps[*]}"
  ((failed > 0)) || failed=1  # a step that failed without a counted test failure (a crash, a missing binary)
fi
echo "tests: $passed passed, $failed failed$( ((skipped > 0)) && echo ", $skipped skipped")"
((${#failed_steps[@]} == 0))
