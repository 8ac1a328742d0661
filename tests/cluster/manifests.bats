#!/usr/bin/env bats
# The deployment files (docker/compose.yaml, docker/nginx.conf, docker/k8s/): Kubernetes schema validation and
# the fields docs/cluster.md promises, by tests/cluster/check_manifests.mjs (kubernetes-models and yaml, npm
# dev dependencies of package.json). No container or cluster is started.

load ../http/helpers/server.bash

@test "docker/k8s and docker/compose.yaml: valid, with probes, grace, limits, non-root, read-only root" {
  require_tools
  "$LIPMAP" serve --help >"$BATS_TEST_TMPDIR/serve-help.txt"
  run node "$BATS_TEST_DIRNAME/check_manifests.mjs" "$HTTP_ROOT" "$BATS_TEST_TMPDIR/serve-help.txt"
  echo "$output"
  [ "$status" -eq 0 ]
  # Not vacuous: the Kubernetes objects were validated.
  [ "$(grep -c 'is valid against the Kubernetes schema' <<<"$output")" -ge 6 ]
}

@test "the manifest check refuses a Deployment without its probes and a wrong type" {
  require_tools
  "$LIPMAP" serve --help >"$BATS_TEST_TMPDIR/serve-help.txt"
  local copy="$BATS_TEST_TMPDIR/root"
  mkdir -p "$copy/docker"
  cp -r "$HTTP_ROOT/docker/k8s" "$HTTP_ROOT/docker/compose.yaml" "$HTTP_ROOT/docker/nginx.conf" "$copy/docker/"
  ln -s "$HTTP_ROOT/node_modules" "$copy/node_modules"
  sed -i -e 's|path: /readyz|path: /ready|' -e 's|containerPort: 8080|containerPort: "eighty"|' "$copy/docker/k8s/deployment.yaml"
  run node "$BATS_TEST_DIRNAME/check_manifests.mjs" "$copy" "$BATS_TEST_TMPDIR/serve-help.txt"
  echo "$output"
  [ "$status" -eq 1 ]
  grep -q '^not ok .* readiness probe on /readyz' <<<"$output"
  grep -q '^not ok .*Deployment lipmap is valid against the Kubernetes schema: .*containerPort' <<<"$output"
}
