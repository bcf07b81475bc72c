#!/usr/bin/env bash
# Bounded black-box fuzz of `wsm serve` from its own OpenAPI document (design §5.3; docs/service.md,
# "Fuzzing"), run by .ci/run: schemathesis (PyPI, in a virtual environment) generates requests for
# every operation — MAX_EXAMPLES each, plus its coverage and stateful phases — against a fresh
# server on a free loopback port, and fails on any 5xx or an answer slower than 20 s; /healthz must
# answer afterwards. Usage: scripts/fuzz_openapi.sh [WSM_BINARY] [MAX_EXAMPLES]
# Needs python3 with venv; installs schemathesis 4 from PyPI (no browser, no Docker).
set -euo pipefail
wsm=${1:-target/release/wsm}
examples=${2:-30}
work=$(mktemp -d)
. "$(dirname "$0")/scratch_server.sh" fuzz.db

venv="${WSM_FUZZ_VENV:-$work/venv}"
[ -x "$venv/bin/st" ] || { python3 -m venv "$venv" && "$venv/bin/pip" install -q 'schemathesis==4.*'; }
echo "== fuzz: schemathesis against $base/openapi.json, $examples examples per operation"
# From the scratch folder: schemathesis keeps its cache (.schemathesis/) in the working directory.
(cd "$work" && timeout 900 "$venv/bin/st" run "$base/openapi.json" --checks not_a_server_error \
  --max-response-time 20 --max-examples "$examples" --workers 1 --request-timeout 30 --seed 1)
curl -fsS --max-time 2 "$base/healthz" > /dev/null
echo "fuzz: no server error, /healthz answers"
