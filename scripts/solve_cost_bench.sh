#!/usr/bin/env bash
# Solve-cost estimate against measurement (design §3.1, "Cost before solving"; docs/benchmarks.md,
# "Solve cost estimate against measurement"): for each case, the estimate printed by a refusal under
# a 1-byte limit (triangles, pairs, bytes), then the real solve's mesh counts, peak RSS
# (/usr/bin/time -v) and wall time; the dense contact path forced where marked, the sparse path
# taken from 1,500 pairs otherwise. Not part of the test suite (minutes).
# Usage: scripts/solve_cost_bench.sh [path/to/wsm]   (prints a Markdown table)
set -euo pipefail
WSM=${1:-target/release/wsm}
DIR=$(mktemp -d)
trap 'rm -rf "$DIR"' EXIT
DENSE='.solver = {"contact": "dense"}'
BAND='.mesh = {"max_size": 0.25, "refine": [{"polygon": [[-0.3, -0.000228], [0.3, -0.000228], [0.3, 0.000228], [-0.3, 0.000228]], "max_size": 0.000114}]}'
cases=(
  "block-on-base|.mesh.refine[0].max_size = 0.004"
  "block-on-base|.mesh.refine[0].max_size = 0.002"
  "block-on-base|.mesh.refine[0].max_size = 0.001 | $DENSE"
  "block-on-base|.mesh.refine[0].max_size = 0.0007 | $DENSE"
  "hertz|.mesh.refine[0].max_size = 0.004"
  "tunnel-fault|.mesh.refine[0].max_size = 0.05 | $DENSE"
  # The sparse contact path (from 1,500 pairs by default):
  "tunnel-fault|.mesh.refine[0].max_size = 0.05"
  "block-on-base|.mesh.refine[0].max_size = 0.0005"
  "block-on-base|.mesh.refine[0].max_size = 0.0002"
  "hertz|$BAND"
)
echo "| case | triangles est / real | pairs est / real | memory est / peak RSS | time est / real |"
echo "|---|---|---|---|---|"
for c in "${cases[@]}"; do
  name=${c%%|*}; edit=${c#*|}
  "$WSM" example "$name" | jq "$edit" > "$DIR/scene.json"
  est=$("$WSM" solve --max-solve-memory 1 "$DIR/scene.json" 2>&1 >/dev/null || true)
  /usr/bin/time -v "$WSM" solve --max-solve-memory 1T "$DIR/scene.json" > "$DIR/out.json" 2> "$DIR/time.txt"
  tri=$(jq .mesh.triangles "$DIR/out.json"); pairs=$(jq .mesh.contact_pairs "$DIR/out.json")
  rss=$(awk '/Maximum resident/ {printf "%.0f MB", $6/1024}' "$DIR/time.txt")
  wall=$(awk -F': ' '/Elapsed/ {print $2}' "$DIR/time.txt")
  echo "| $name, ${edit//|/;} | $(sed -E 's/.*about ([0-9.,e]+) triangles.*/\1/' <<<"$est") / $tri | $(sed -E 's/.*and ([0-9.,e]+) contact pairs.*/\1/' <<<"$est") / $pairs | $(sed -E 's/.*need about ([0-9.]+ [MG]B).*/\1/' <<<"$est") / $rss | $(sed -E 's/.*of memory \(and about ([^)]*)\).*/\1/' <<<"$est") / $wall |"
done
