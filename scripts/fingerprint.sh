#!/usr/bin/env bash
# Fingerprints of every bundled example's `wsm worst` result (docs/build.md, "Bit-identical
# results"): one line per example, the SHA-256 of the result JSON with run times and host facts
# removed. Run it before and after a change that must not change results and diff the two files:
#   scripts/fingerprint.sh target/release/wsm > before.txt
# Each run is deterministic (one thread, a fixed seed and budget); dynamic examples are run on
# a short budget too. A run that fails prints its error class instead of a hash.
set -uo pipefail
WSM=${1:-target/release/wsm}
BUDGET=${BUDGET:-16}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for name in $("$WSM" example --list | awk '{print $1}'); do
  "$WSM" example "$name" > "$work/$name.json" 2>/dev/null || continue
  run() {
    timeout 300 "$WSM" worst "$work/$name.json" --budget "$BUDGET" --seed 1 --threads 1 \
      --out "$work/$name.out.json" "$@" > /dev/null 2> "$work/$name.err"
  }
  # A scene that names no criteria in its `search` (the dynamic examples) is run on Φ3 and Φ5.
  if run || { grep -q "no criterion requested" "$work/$name.err" && run --criteria phi3,phi5; }; then
    hash=$(python3 - "$work/$name.out.json" <<'PY'
import hashlib, json, sys
TIMING = ("seconds", "elapsed", "timings", "time_s", "wall", "cpu", "started", "finished",
          "created", "host", "threads_used", "duration", "per_second", "time_share")
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items()
                if not any(t in k.lower() for t in TIMING)}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
doc = strip(json.load(open(sys.argv[1])))
print(hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()[:16])
PY
)
    echo "$name $hash"
  else
    echo "$name failed: $(tail -1 "$work/$name.err" | cut -c1-100)"
  fi
done
