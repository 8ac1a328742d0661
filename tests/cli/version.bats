#!/usr/bin/env bats
# `lipmap --version`: one line "lipmap X.Y.Z" on standard output, exit 0, where X.Y.Z is the version in the
# top-level CMakeLists.txt's project() line (read here from that file, not from the binary).

bats_require_minimum_version 1.5.0

setup() {
  ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
  LIPMAP="${LIPMAP_BIN:-$ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
  PROJECT_VERSION="$(sed -n 's/^project(lipmap VERSION \([0-9][0-9.]*\).*/\1/p' "$ROOT/CMakeLists.txt")"
  [ -n "$PROJECT_VERSION" ] || { echo "no project(lipmap VERSION ...) line in CMakeLists.txt" >&2; return 1; }
}

@test "--version prints the CMake project version and exits 0" {
  run --separate-stderr "$LIPMAP" --version
  [ "$status" -eq 0 ]
  [ "$output" = "lipmap $PROJECT_VERSION" ]
  [ -z "$stderr" ]
}

@test "--version needs no subcommand and runs none" {
  run --separate-stderr "$LIPMAP" --version
  [ "${#lines[@]}" -eq 1 ]
  [[ "$output" != *verdict* ]]
}

@test "--help lists --version" {
  run "$LIPMAP" --help
  [ "$status" -eq 0 ]
  [[ "$output" == *--version* ]]
}

@test "an unknown flag is still a usage error (exit 2), not a version" {
  run --separate-stderr "$LIPMAP" --versio
  [ "$status" -eq 2 ]
  [[ "$stderr" == "lipmap: error: usage: "* ]]
}
