#!/usr/bin/env bash
# Smoke test of a running `wsm serve` with curl and standard tools only.
# Usage: scripts/smoke.sh [BASE_URL]   (default http://127.0.0.1:8080)
# Exit status 0 only when every step passed. Set WSM_API_TOKEN when the server requires it.
set -uo pipefail
BASE=${1:-http://127.0.0.1:8080}
AUTH=()
if [ -n "${WSM_API_TOKEN:-}" ]; then AUTH=(-H "Authorization: Bearer ${WSM_API_TOKEN}"); fi
failures=0
step() { printf '%-58s' "$1"; }
ok() { echo "ok${1:+ ($1)}"; }
fail() { echo "FAILED: $1"; failures=$((failures + 1)); }
body=$(mktemp); trap 'rm -f "$body"' EXIT

step "health"
code=$(curl -s -o "$body" -w '%{http_code}' "$BASE/healthz")
if [ "$code" = 200 ] && grep -q '"status":"ok"' "$body"; then ok; else fail "HTTP $code $(cat "$body")"; fi

step "list the examples"
code=$(curl -s -o "$body" -w '%{http_code}' "$BASE/v1/examples")
if [ "$code" = 200 ] && grep -q '"name":"block-on-base"' "$body"; then ok "$(grep -o '"name":"[^"]*"' "$body" | wc -l) examples"; else fail "HTTP $code"; fi

step "submit block-on-base with a small budget"
code=$(curl -s -o "$body" -w '%{http_code}' "${AUTH[@]}" -H 'Content-Type: application/json' \
  -d '{"example":"block-on-base","settings":{"criteria":["phi3","phi6"],"budget":20,"seed":1}}' \
  "$BASE/v1/jobs")
id=$(grep -o '"id":"[^"]*"' "$body" | head -1 | cut -d'"' -f4)
if [ "$code" = 202 ] && [ -n "$id" ]; then ok "job $id"; else fail "HTTP $code $(cat "$body")"; fi

step "follow the job to completion"
state=""
for _ in $(seq 1 600); do
  curl -s -o "$body" "$BASE/v1/jobs/$id"
  state=$(grep -o '"state":"[^"]*"' "$body" | head -1 | cut -d'"' -f4)
  case "$state" in succeeded|failed|cancelled) break ;; esac
  sleep 0.2
done
if [ "$state" = succeeded ]; then ok "$(grep -o '"evaluations":[0-9]*' "$body" | head -1)"; else fail "state '$state' $(cat "$body")"; fi

step "fetch the result: data, gradient, certificate"
code=$(curl -s -o "$body" -w '%{http_code}' "$BASE/v1/jobs/$id/result")
if [ "$code" = 200 ] && grep -q '"criterion":"phi3"' "$body" && grep -q '"criterion":"phi6"' "$body" \
   && grep -q '"value":[-0-9]' "$body" && grep -q '"point":\[' "$body" \
   && grep -qF '"data":{"boundary[2].traction[0]":' "$body" \
   && grep -qF '"gradient":{"boundary[2].traction[0]":{"right":' "$body" && grep -q '"certificate":{"verdict":"' "$body"; then
  ok "$(grep -o '"value":[^,]*' "$body" | head -1), $(grep -o '"verdict":"[^"]*"' "$body" | sort | uniq -c | tr -s ' ' | tr '\n' ' ')"
else fail "HTTP $code"; fi

step "evaluations as CSV"
code=$(curl -s -o "$body" -w '%{http_code}' "$BASE/v1/jobs/$id/evaluations?format=csv")
if [ "$code" = 200 ] && head -1 "$body" | grep -q '^id,materials.rock.E,'; then ok "$(($(wc -l < "$body") - 1)) rows"; else fail "HTTP $code"; fi

step "an invalid scene answers 422 with the JSON path"
scene=$(curl -s "$BASE/v1/examples/block-on-base" | sed 's/"E":[-0-9.e+]*/"E":-1.0/')
code=$(curl -s -o "$body" -w '%{http_code}' "${AUTH[@]}" -H 'Content-Type: application/json' \
  -d "{\"scene\":$scene}" "$BASE/v1/jobs")
path=$(grep -o '"path":"[^"]*"' "$body" | cut -d'"' -f4)
if [ "$code" = 422 ] && [ "$path" = "scene.materials.rock.E" ]; then ok "path $path"; else fail "HTTP $code $(cat "$body")"; fi

if [ "$failures" -eq 0 ]; then echo "smoke: all steps passed"; exit 0; fi
echo "smoke: $failures step(s) failed"; exit 1
