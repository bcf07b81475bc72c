#!/usr/bin/env bash
# Scale-out benchmark (docs/scale-out.md, "Benchmark"; not part of the test suite): evaluations per
# second of one worst-scenario job on the tunnel (`tunnel-fault`, its mesh sizes multiplied by
# SCALE) with 1, 2, ... `wsm worker` processes of one thread each on a PostgreSQL store, beside the
# same run in one process without a store (`wsm worst --threads 1` and `--threads 2`).
#
# Usage: scripts/scale_bench.sh [WORKER_COUNTS (default "1 2")]
# Environment: WSM_BIN (default target/release/wsm), PG_URL (default
# postgres://postgres@127.0.0.1:5432/test), BUDGET (default 400), SCALE (default 1), RUNS
# (default 3; the median is printed), CRITERIA (default phi3,phi5), DERIVATIVES (default true;
# false searches without exact derivatives). Every run gets a fresh schema, dropped afterwards.
# Besides the search's own evaluations/s, the table gives the whole job's time (median): from the
# command's start (one process) or the job's submission (workers) to its result, which includes
# meshing, the nominal solve and the accuracy statement (its seconds in the last column).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${WSM_BIN:-target/release/wsm}
url=${PG_URL:-postgres://postgres@127.0.0.1:5432/test}
budget=${BUDGET:-400}
scale=${SCALE:-1}
runs=${RUNS:-3}
counts=${1:-"1 2"}
criteria=${CRITERIA:-phi3,phi5}
derivatives=${DERIVATIVES:-true}
local_flags=()
[ "$derivatives" = false ] && local_flags+=(--no-derivatives)
work=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

"$bin" example tunnel-fault | python3 -c "
import json, sys
s = json.load(sys.stdin)
f = float('$scale')
s['mesh']['max_size'] *= f
for r in s['mesh'].get('refine', []):
    r['max_size'] *= f
json.dump(s, open('$work/scene.json', 'w'))
json.dump({'scene': s, 'settings': {'criteria': '$criteria'.split(','), 'budget': $budget, 'seed': 1,
                                    'derivatives': '$derivatives' == 'true'}},
          open('$work/job.json', 'w'))
"

now() { date +%s.%N; }
elapsed() { python3 -c "import sys; print(float(sys.argv[2]) - float(sys.argv[1]))" "$@"; }
median() { python3 -c "import statistics, sys; print(f'{statistics.median(float(x) for x in sys.argv[1:]):.2f}')" "$@"; }
field() { python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2], {}, {'d': d}))" "$@"; }

echo "load: $(uptime | sed 's/.*load average/load average/')"
echo "tunnel x$scale, criteria $criteria, derivatives $derivatives, budget $budget, median of $runs runs"
echo
echo "| setting | evaluations | search wall [s] | evaluations/s | solver share | job [s] | statement [s] |"
echo "|---|---|---|---|---|---|---|"
for threads in 1 2; do
  rates=()
  jobs=()
  for _ in $(seq "$runs"); do
    start=$(now)
    "$bin" worst "$work/scene.json" --criteria "$criteria" --budget "$budget" --seed 1 \
      --threads "$threads" "${local_flags[@]}" --out "$work/local.json" > /dev/null 2>&1
    jobs+=("$(elapsed "$start" "$(now)")")
    rates+=("$(field "$work/local.json" "d['evaluations_per_second']")")
  done
  echo "| one process, $threads thread(s), no store | $(field "$work/local.json" "d['new_evaluations']") | $(field "$work/local.json" "round(d['wall_seconds'], 2)") | $(median "${rates[@]}") | $(field "$work/local.json" "round(d['inner_time_share'], 2)") | $(median "${jobs[@]}") | $(field "$work/local.json" "round((d.get('accuracy') or {}).get('seconds', 0), 2)") |"
done

for n in $counts; do
  rates=()
  jobs=()
  for _ in $(seq "$runs"); do
    schema="wsm_bench_$(python3 -c 'import uuid; print(uuid.uuid4().hex)')"
    PGOPTIONS=--client-min-messages=warning psql -q "$url" -c "CREATE SCHEMA $schema"
    db="$url?options=-c%20search_path%3D$schema"
    "$bin" serve --addr 127.0.0.1:0 --db "$db" --workers 0 > "$work/serve.log" 2>&1 &
    pids+=($!)
    for _ in $(seq 100); do grep -q 'http://' "$work/serve.log" && break; sleep 0.1; done
    base=$(grep -o 'http://[0-9.:]*' "$work/serve.log" | head -1)
    for _ in $(seq "$n"); do
      "$bin" worker --db "$db" --threads 1 > /dev/null 2>&1 &
      pids+=($!)
    done
    sleep 1
    start=$(now)
    id=$(curl -fsS -H 'Content-Type: application/json' --data @"$work/job.json" "$base/v1/jobs" |
      python3 -c "import json, sys; print(json.load(sys.stdin)['id'])")
    until curl -fsS "$base/v1/jobs/$id" | grep -Eq '"state":"(succeeded|failed|cancelled)"'; do sleep 0.1; done
    jobs+=("$(elapsed "$start" "$(now)")")
    curl -fsS "$base/v1/jobs/$id/result" > "$work/remote.json"
    rates+=("$(field "$work/remote.json" "d['evaluations_per_second']")")
    cleanup
    pids=()
    wait 2>/dev/null || true
    PGOPTIONS=--client-min-messages=warning psql -q "$url" -c "DROP SCHEMA $schema CASCADE"
  done
  echo "| $n worker process(es) x 1 thread, PostgreSQL | $(field "$work/remote.json" "d['new_evaluations']") | $(field "$work/remote.json" "round(d['wall_seconds'], 2)") | $(median "${rates[@]}") | $(field "$work/remote.json" "round(d['inner']['solver_seconds'] / d['wall_seconds'] / $n, 2)") | $(median "${jobs[@]}") | $(field "$work/remote.json" "round((d.get('accuracy') or {}).get('seconds', 0), 2)") |"
done
