#!/usr/bin/env bash
# The layout rules of docs/architecture.md, checked on the tree (TAP output, one line per rule):
# small source files, engine/detail private to the engine, CGAL out of public headers, no HTTP or JSON in the
# engine, documentation that links only files inside the repository, no dependence on folders beside it.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

n=0 failed=0
check() {  # check DESCRIPTION OFFENDERS: ok when OFFENDERS is empty
  n=$((n + 1))
  if [[ -z "$2" ]]; then
    echo "ok $n $1"
  else
    failed=$((failed + 1))
    echo "not ok $n $1"
    sed 's/^/#   /' <<<"$2"
  fi
}
sources() { git ls-files -- 'engine/*.h' 'engine/*.cpp' 'server/*.h' 'server/*.cpp' 'tests/*.h' 'tests/*.cpp' 'tests/*.js' 'bench/*.cpp'; }

echo "1..7"
check "no source file over 800 lines" \
  "$(sources | xargs wc -l | awk '$2 != "total" && $1 > 800 {print $2 ": " $1 " lines"}')"
check "engine/detail is included only by engine/ and tests/engine/" \
  "$(git grep -l '#include "engine/detail/' -- ':!engine/' ':!tests/engine/' ':!tests/layout/' || true)"
check "engine's public headers do not include CGAL" \
  "$(git grep -l '#include <CGAL/' -- ':(glob)engine/*.h' || true)"
check "no HTTP and no JSON inside engine/" \
  "$(git grep -lE '#include <(httplib|nlohmann/)' -- 'engine/' || true)"
# The pattern is spelled in two pieces so that this file does not name what it looks for.
beside='\.\./''shared|DESIGN''\.md'
check "nothing refers to the founding notes beside the repository" \
  "$(git grep -lE "$beside" -- ':!tests/layout/check_layout.sh' || true)"
# Markdown links [text](target) in README.md and docs/: every relative target exists in the repository.
links=""
while IFS= read -r md; do
  dir="$(dirname "$md")"
  while IFS= read -r target; do
    target="${target%%#*}"
    [[ -z "$target" || "$target" =~ ^[a-z]+: ]] && continue
    [[ -e "$dir/$target" ]] || links+="$md: $target"$'\n'
    case "$(realpath -m "$dir/$target")" in "$PWD"/*) ;; *) links+="$md: $target (outside the repository)"$'\n' ;; esac
  done < <(grep -oE '\]\([^)]+\)' "$md" | sed -E 's/^\]\((.*)\)$/\1/')
done < <(git ls-files -- README.md 'docs/*.md' 'tests/data/*.md')
check "README.md and docs/ link only files inside the repository" "${links%$'\n'}"
check "no issue-tracker words in code, docs or the API document" \
  "$(git grep -nE '\b[Ii]ssue [0-9]+' -- ':!tests/layout/check_layout.sh' || true)"

echo "# layout: $((n - failed)) passed, $failed failed"
((failed == 0))
