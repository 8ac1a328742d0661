# Shared by tests/cluster/*.bats: a Redis, three `lipmap serve --queue-url` replicas and nginx (round robin)
# in front, all on loopback and unprivileged, under $BATS_FILE_TMPDIR; a single process without the queue
# gives the reference answers. Every wait is bounded; teardown_file stops everything.
# Needs: redis-server, nginx, curl, jq, node (for free ports and the answer checks), a built binary.

load ../http/helpers/server.bash

CLUSTER_VISIBILITY="${CLUSTER_VISIBILITY:-2}"  # seconds: short, so that a takeover happens within the test

free_port() {
  node -e 'const s=require("net").createServer();s.listen(0,"127.0.0.1",()=>{console.log(s.address().port);s.close()})'
}

require_cluster_tools() {
  require_tools
  command -v redis-server >/dev/null || { echo "redis-server is needed (scripts/setup.sh --with-tests)" >&2; return 1; }
  command -v nginx >/dev/null || [ -x /usr/sbin/nginx ] || { echo "nginx is needed (scripts/setup.sh --with-tests)" >&2; return 1; }
}

nginx_bin() { command -v nginx || echo /usr/sbin/nginx; }

# wait_until SECONDS COMMAND...: polls COMMAND every 0.1 s until it succeeds; fails after SECONDS.
wait_until() {
  local limit="$1"; shift
  local i
  for i in $(seq $((limit * 10))); do
    "$@" 2>/dev/null && return 0
    sleep 0.1
  done
  echo "not true after $limit s: $*" >&2
  return 1
}

# start_redis: Redis on REDIS_PORT with an append-only file under the test folder (a restart keeps the
# queue, as a production Redis with persistence does).
start_redis() {
  mkdir -p "$BATS_FILE_TMPDIR/redis"
  redis-server --port "$REDIS_PORT" --bind 127.0.0.1 --save '' --appendonly yes --appendfsync always \
    --dir "$BATS_FILE_TMPDIR/redis" --daemonize no --loglevel warning >>"$BATS_FILE_TMPDIR/redis.log" 2>&1 &
  echo "$!" >"$BATS_FILE_TMPDIR/redis.pid"  # a test restarts it: teardown_file must find the new one
  wait_until 10 redis_ping
}
redis_ping() { [ "$(redis-cli -p "$REDIS_PORT" ping 2>/dev/null)" = PONG ]; }
stop_redis() {
  local pid
  pid="$(cat "$BATS_FILE_TMPDIR/redis.pid" 2>/dev/null)" || return 0
  kill -TERM "$pid" 2>/dev/null || return 0
  wait_until 20 bash -c "! kill -0 $pid" || kill -KILL "$pid" 2>/dev/null || true
}

# start_replica N: replica N (1..3, or 4 for a test's own) on REPLICA<N>_PORT, one worker; its queue (the
# cluster-wide cap, and the length of its own pool's queue) is REPLICA_QUEUE (64).
start_replica() {
  local n="$1" port_var="REPLICA${1}_PORT"
  local port="${!port_var}"
  "$LIPMAP" serve --host 127.0.0.1 --port "$port" --workers 1 --queue "${REPLICA_QUEUE:-64}" --test-hooks \
    --queue-url "redis://127.0.0.1:$REDIS_PORT" --queue-visibility "$CLUSTER_VISIBILITY" \
    2>>"$BATS_FILE_TMPDIR/replica$n.log" &
  # The pid in a file: a replica restarted by one test must be known to the next ones and to teardown_file.
  echo "$!" >"$BATS_FILE_TMPDIR/replica$n.pid"
  printf -v "REPLICA${n}_URL" 'http://127.0.0.1:%s' "$port"
  export "REPLICA${n}_URL"
  wait_until 20 curl -sf --max-time 2 "http://127.0.0.1:$port/readyz" -o /dev/null
}

start_nginx() {
  local d="$BATS_FILE_TMPDIR/nginx"
  mkdir -p "$d"
  # nginx started by root switches its workers to "nobody", who could not write the temp folders here.
  local user=""
  [ "$(id -u)" = 0 ] && user="user root root;"
  cat >"$d/nginx.conf" <<CONF
daemon off;
$user
worker_processes 1;
pid $d/nginx.pid;
error_log $d/error.log warn;
events { worker_connections 512; }
http {
  access_log off;
  client_body_temp_path $d/body;
  proxy_temp_path $d/proxy;
  fastcgi_temp_path $d/fastcgi;
  uwsgi_temp_path $d/uwsgi;
  scgi_temp_path $d/scgi;
  client_max_body_size 256m;
  upstream lipmap {
    server 127.0.0.1:$REPLICA1_PORT max_fails=0;
    server 127.0.0.1:$REPLICA2_PORT max_fails=0;
    server 127.0.0.1:$REPLICA3_PORT max_fails=0;
  }
  server {
    listen 127.0.0.1:$NGINX_PORT;
    location / {
      proxy_pass http://lipmap;
      proxy_http_version 1.1;
      proxy_set_header Connection "";
      proxy_read_timeout 300s;
      proxy_next_upstream error timeout;
    }
  }
}
CONF
  "$(nginx_bin)" -p "$d" -c "$d/nginx.conf" -e "$d/error.log" &
  NGINX_PID=$!
  NGINX_URL="http://127.0.0.1:$NGINX_PORT"
  export NGINX_PID NGINX_URL
  wait_until 10 curl -sf --max-time 2 "$NGINX_URL/healthz" -o /dev/null
}

replica_pid() { cat "$BATS_FILE_TMPDIR/replica$1.pid"; }
replica_alive() { kill -0 "$(replica_pid "$1")" 2>/dev/null; }

# stop_replica N [SIGNAL]: SIGTERM (or SIGNAL), and at most 30 s for the exit.
stop_replica() {
  local pid
  pid="$(replica_pid "$1" 2>/dev/null)" || return 0
  kill -"${2:-TERM}" "$pid" 2>/dev/null || return 0
  wait_until 30 bash -c "! kill -0 $pid" || { kill -KILL "$pid" 2>/dev/null; return 1; }
}

setup_cluster() {
  require_cluster_tools
  REDIS_PORT="$(free_port)" NGINX_PORT="$(free_port)"
  REPLICA1_PORT="$(free_port)" REPLICA2_PORT="$(free_port)" REPLICA3_PORT="$(free_port)"
  export REDIS_PORT NGINX_PORT REPLICA1_PORT REPLICA2_PORT REPLICA3_PORT
  start_redis
  start_replica 1
  start_replica 2
  start_replica 3
  start_nginx
  start_server SINGLE --workers 1  # the reference: one process, in-memory jobs
}

teardown_cluster() {
  [ -n "${NGINX_PID:-}" ] && kill -QUIT "$NGINX_PID" 2>/dev/null
  local n
  for n in 1 2 3 4; do stop_replica "$n" || true; done
  stop_server SINGLE || true
  stop_redis
  [ -n "${NGINX_PID:-}" ] && { wait_until 10 bash -c "! kill -0 $NGINX_PID" || kill -KILL "$NGINX_PID" 2>/dev/null; }
  return 0
}

# running_replica: the replica whose worker is busy (its /metrics say so), printed as its number.
running_replica() {
  local n url
  for n in 1 2 3; do
    url="REPLICA${n}_URL"
    replica_alive "$n" || continue
    if curl -sf --max-time 2 "${!url}/metrics" | grep -qx 'lipmap_workers_busy 1'; then echo "$n"; return 0; fi
  done
  return 1
}

# reference NAME BODY_FILE: the single process's synchronous answer for BODY_FILE, once, in $BATS_FILE_TMPDIR.
reference() {
  local f="$BATS_FILE_TMPDIR/reference.$1"
  [ -s "$f" ] || curl -sf --max-time 120 --json "@$2" "$SINGLE_URL/v1/parametrize" -o "$f"
  echo "$f"
}

# same_answer A B: the two answers are the same up to their wall-clock timings (same_answer.js).
same_answer() { node "$BATS_TEST_DIRNAME/same_answer.js" "$1" "$2"; }

# submit URL BODY_FILE [curl options]: POST /v1/jobs; prints the job id.
# (Not with `call`: this runs in a subshell, whose answer numbers the caller would reuse.)
submit() {
  local url="$1" bodyf="$2"; shift 2
  local f status
  f="$(mktemp "$BATS_TEST_TMPDIR/submitted.XXXXXX")"
  status="$(curl -sS -o "$f" -w '%{http_code}' --max-time 60 --json "@$bodyf" "$@" "$url/v1/jobs")" || return 1
  [ "$status" = 202 ] || { echo "POST /v1/jobs: HTTP $status: $(head -c 400 "$f")" >&2; return 1; }
  echo "schema job.schema.json $f" >>"$BATS_TEST_TMPDIR/manifest"
  jq -r .id "$f"
}

# wait_final URL ID SECONDS: polls until the job is final; prints its state.
wait_final() {
  local url="$1" id="$2" limit="$3" i state=""
  for i in $(seq $((limit * 10))); do
    state="$(curl -s --max-time 5 "$url/v1/jobs/$id" | jq -r .state 2>/dev/null || true)"
    case "$state" in succeeded|failed|cancelled) echo "$state"; return 0 ;; esac
    sleep 0.1
  done
  echo "job $id still '$state' after $limit s" >&2
  return 1
}
