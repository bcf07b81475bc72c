# Sourced by the scripts that probe a running service: starts `$wsm serve` on a free loopback
# port with a scratch database in `$work` (one job slot, one thread, budgets ≤ 200), stops it and
# removes `$work` on exit, and sets `server` (its pid) and `base` (its URL).
# Needs: `wsm` (the binary) and `work` (a scratch folder) set by the caller; `$1` names the
# database file.
"$wsm" serve --addr 127.0.0.1:0 --db "$work/$1" --workers 1 --threads-per-job 1 \
  --max-budget 200 > "$work/serve.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 1 100); do grep -q 'http://' "$work/serve.log" && break; sleep 0.1; done
base=$(grep -o 'http://[0-9.:]*' "$work/serve.log" | head -1)
