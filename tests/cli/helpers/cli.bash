# Shared by tests/cli/*.bats: run the binary ($LIPMAP, set by each file's setup) with stdout and stderr apart,
# and the CLI's error contract: exit status, nothing on stdout, one stderr line "lipmap: error: CODE: ...".

lipmap() { run --separate-stderr "$LIPMAP" "$@"; }

expect_error() {
  local status_wanted="$1" code="$2"
  [ "$status" -eq "$status_wanted" ] || { echo "status $status, wanted $status_wanted; stderr: $stderr" >&2; return 1; }
  [ -z "$output" ] || { echo "stdout not empty: $output" >&2; return 1; }
  [ "${#stderr_lines[@]}" -eq 1 ] || { echo "stderr has ${#stderr_lines[@]} lines: $stderr" >&2; return 1; }
  [[ "$stderr" == "lipmap: error: $code: "* ]] || { echo "stderr: $stderr (wanted code $code)" >&2; return 1; }
}
