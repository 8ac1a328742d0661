# Shared by the tests/http/*.bats suites: start the real `lipmap serve` on a free loopback port, call it with
# curl, and collect every answer for check_answers.js (JSON Schemas of proto/, docs/contract.md checks).
# Everything targets 127.0.0.1; every loop is bounded.
#
# Needs: curl, jq, node with the dev dependencies of package.json (npm ci), and a built binary: $LIPMAP_BIN,
# or ${LIPMAP_BUILD_DIR:-build}/server/lipmap.

HTTP_ROOT="$(cd "$BATS_TEST_DIRNAME/../.." && pwd)"
HELPERS="$HTTP_ROOT/tests/http/helpers"
LIPMAP="${LIPMAP_BIN:-$HTTP_ROOT/${LIPMAP_BUILD_DIR:-build}/server/lipmap}"

require_tools() {
  [ -x "$LIPMAP" ] || { echo "lipmap binary not found at $LIPMAP (build first, or set LIPMAP_BIN)" >&2; return 1; }
  command -v curl >/dev/null && command -v jq >/dev/null && command -v node >/dev/null ||
    { echo "curl, jq and node are needed" >&2; return 1; }
}

# start_server NAME [serve options...]: starts lipmap serve on 127.0.0.1, port 0 (the kernel picks a free
# one), logging to $BATS_FILE_TMPDIR/NAME.log; waits (at most 10 s) for its "listening" line. Sets
# <NAME>_URL and <NAME>_PID (e.g. MAIN_URL, MAIN_PID) and exports them.
start_server() {
  local name="$1"; shift
  local log="$BATS_FILE_TMPDIR/$name.log"
  "$LIPMAP" serve --host 127.0.0.1 --port 0 "$@" 2>"$log" &
  local pid=$!
  local port="" i
  for i in $(seq 100); do
    port="$(grep -m1 '"event":"listening"' "$log" 2>/dev/null | jq -r .port 2>/dev/null || true)"
    [ -n "$port" ] && [ "$port" != null ] && break
    kill -0 "$pid" 2>/dev/null || { echo "server $name exited at start:" >&2; cat "$log" >&2; return 1; }
    sleep 0.1
  done
  [ -n "$port" ] && [ "$port" != null ] || { echo "server $name did not start:" >&2; cat "$log" >&2; kill "$pid"; return 1; }
  printf -v "${name}_URL" 'http://127.0.0.1:%s' "$port"
  printf -v "${name}_PID" '%s' "$pid"
  export "${name}_URL" "${name}_PID"
}

# serve_for_file NAME [serve options...]: the suites' setup_file: the tools checked, then one service for the
# whole file (stopped by its teardown_file with stop_server NAME).
serve_for_file() {
  require_tools
  start_server "$@"
}

# Every test's answers are checked after it (a suite that stops servers of its own defines its own teardown,
# which calls check_recorded_answers too).
teardown() { check_recorded_answers; }

# stop_server NAME [SIGNAL]: SIGTERM (or SIGNAL) and wait (at most 30 s) for the exit; the exit status is
# in $stop_status.
stop_server() {
  local pid_var="${1}_PID"
  local pid="${!pid_var:-}"
  stop_status=""
  [ -n "$pid" ] || return 0
  kill -"${2:-TERM}" "$pid" 2>/dev/null || true
  local i
  for i in $(seq 300); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  if kill -0 "$pid" 2>/dev/null; then
    echo "server $1 (pid $pid) did not stop within 30 s" >&2
    kill -KILL "$pid" 2>/dev/null || true
    stop_status=timeout
    return 1
  fi
  wait "$pid" 2>/dev/null
  stop_status=$?
}

# call [-s SCHEMA] METHOD URL [curl options...]: one request. Sets $code (HTTP status), $body (the body),
# $ctype (Content-Type), $answer (file holding the body), $hdrs (file holding the headers), and records the
# answer for check: problems against problem.schema.json, 2xx JSON answers against SCHEMA when given.
# Every problem must also say the status it was sent with and carry the X-Request-Id it was sent under.
answer_no=0
call() {
  local schema=""
  if [ "$1" = "-s" ]; then schema="$2"; shift 2; fi
  local method="$1" url="$2"; shift 2
  answer_no=$((answer_no + 1))
  answer="$BATS_TEST_TMPDIR/answer.$answer_no"
  hdrs="$BATS_TEST_TMPDIR/headers.$answer_no"
  local verb=(-X "$method")
  [ "$method" = HEAD ] && verb=(--head)
  code="$(curl -sS "${verb[@]}" -o "$answer" -D "$hdrs" -w '%{http_code}' --max-time 120 "$@" "$url")" || {
    echo "curl $method $url failed" >&2; return 1; }
  body="$(cat "$answer")"
  ctype="$(header Content-Type)"
  if [[ "$ctype" == application/problem+json* ]]; then
    echo "schema problem.schema.json $answer" >>"$BATS_TEST_TMPDIR/manifest"
    [ "$(jq -r .status "$answer")" = "$code" ] || { echo "problem status $(jq .status "$answer") != HTTP $code" >&2; return 1; }
    [ "$(jq -r .request_id "$answer")" = "$(header X-Request-Id)" ] || { echo "problem request_id != X-Request-Id" >&2; return 1; }
    [ "$(jq -r .type "$answer")" = "urn:lipmap:problem:$(jq -r .code "$answer")" ] || { echo "type/code mismatch" >&2; return 1; }
  elif [ -n "$schema" ] && [[ "$code" == 2* ]]; then
    echo "schema $schema $answer" >>"$BATS_TEST_TMPDIR/manifest"
  fi
  # The service answers 5xx only for internal bugs (500), overload/shutdown (503) and deadlines (504).
  case "$code" in 5*) [[ "$code" == 500 || "$code" == 503 || "$code" == 504 ]] || { echo "unexpected $code" >&2; return 1; } ;; esac
  return 0
}

# header NAME: a header of the last answer (case-insensitive name, value without CR).
header() {
  grep -i "^$1:" "$hdrs" | tail -n 1 | sed -E 's/^[^:]*:[[:space:]]*//' | tr -d '\r'
}

# expect CODE [PROBLEM_CODE]: the last answer has this status (and, for a problem, this code).
expect() {
  [ "$code" = "$1" ] || { echo "HTTP $code, wanted $1: $(head -c 600 "$answer")" >&2; return 1; }
  if [ -n "${2:-}" ]; then
    [[ "$ctype" == application/problem+json* ]] || { echo "not a problem answer: $ctype" >&2; return 1; }
    [ "$(jq -r .code "$answer")" = "$2" ] || { echo "problem code $(jq -r .code "$answer"), wanted $2: $body" >&2; return 1; }
  fi
}

# check_map REQUEST_FILE: the last answer (a parametrize answer) is checked against docs/contract.md.
check_map() {
  echo "schema parametrize-answer.schema.json $answer" >>"$BATS_TEST_TMPDIR/manifest"
  echo "map $1 $answer" >>"$BATS_TEST_TMPDIR/manifest"
}

# Runs every check recorded by this test (called by each suite's teardown, so that no answer escapes).
check_recorded_answers() {
  [ -s "$BATS_TEST_TMPDIR/manifest" ] || return 0
  node "$HELPERS/check_answers.js" "$BATS_TEST_TMPDIR/manifest"
}

# make_body NAME ARGS...: writes a request body made by make_request.js to $BATS_FILE_TMPDIR/NAME.json once.
make_body() {
  local name="$1"; shift
  local f="$BATS_FILE_TMPDIR/$name.json"
  [ -s "$f" ] || node "$HELPERS/make_request.js" "$@" >"$f"
  echo "$f"
}

# wait_for_job URL ID STATE...: polls GET /v1/jobs/ID (at most 60 s) until its state is one of STATE...
wait_for_job() {
  local url="$1" id="$2"; shift 2
  local i state
  for i in $(seq 600); do
    call -s job.schema.json GET "$url/v1/jobs/$id" || return 1
    state="$(jq -r .state "$answer")"
    local s
    for s in "$@"; do [ "$state" = "$s" ] && return 0; done
    sleep 0.1
  done
  echo "job $id still $state after 60 s (wanted $*)" >&2
  return 1
}
