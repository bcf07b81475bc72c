#!/usr/bin/env bash
# Benchmarks of the service, outside the test suite (loopback only, bounded in time and count):
#  1. load: while a job runs (one worker, one thread per job), `wrk` hammers GET /v1/jobs/{id}
#     for DURATION seconds with 16 connections and reports requests/s and latency percentiles;
#  2. fuzz: scripts/fuzz_openapi.sh (schemathesis from the served OpenAPI document,
#     MAX_EXAMPLES per operation, no 5xx), the same as .ci/run runs.
# Usage: scripts/load_and_fuzz.sh [WSM_BINARY] [DURATION] [MAX_EXAMPLES]
# Needs: wrk (apt-get install wrk), python3 with venv. Results go to stdout; docs/service.md
# records a run.
set -euo pipefail
wsm=${1:-target/release/wsm}
duration=${2:-10}
examples=${3:-25}
work=$(mktemp -d)
. "$(dirname "$0")/scratch_server.sh" load.db

echo "== load: GET /v1/jobs/{id} while the job runs"
id=$(curl -s -H 'Content-Type: application/json' \
  -d '{"example":"tunnel-fault","settings":{"budget":200,"criteria":["phi3","phi5"]}}' \
  "$base/v1/jobs" | grep -o '"id":"[^"]*"' | cut -d'"' -f4)
sleep 2
curl -s "$base/v1/jobs/$id" | grep -o '"state":"[^"]*"'
wrk -t1 -c16 -d"${duration}s" --latency "$base/v1/jobs/$id"
curl -s "$base/v1/jobs/$id" | grep -o '"state":"[^"]*"\|"evaluations":[0-9]*' | head -2
curl -s -X POST "$base/v1/jobs/$id/cancel" > /dev/null

"$(dirname "$0")/fuzz_openapi.sh" "$wsm" "$examples"
