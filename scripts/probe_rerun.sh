#!/usr/bin/env bash
# Re-measures the counts of the independent probe (docs/service.md, "Robustness") against a
# fresh `wsm serve` (loopback only; bounded: a few hundred requests, at most 2,000 idle
# connections, under two minutes), for docs/service.md ("Re-measured: scripts/probe_rerun.sh"):
#  1. hostile inputs: every value of the block-on-base scene replaced by 6 hostile values, plus
#     the probe's corpus (tests/data/hostile_corpus.json) → how many 4xx name their field, 5xx;
#  2. load: 8 threads of mixed GETs (status, list, events-free reads, /healthz) for LOAD_SECONDS
#     → requests/s, p50/p99, errors;
#  3. idle connections: IDLE connections opened and left idle (server cap MAX_CONNECTIONS) →
#     how /healthz answers meanwhile and after the header timeout;
#  4. a slow client: half a request line → seconds until the server closes it; a stalled body
#     → 408; Content-Length 10^12 → 413 and how fast;
#  5. store outage: another connection holds the SQLite write lock for OUTAGE seconds →
#     /healthz degraded/ok timeline, submissions' statuses, and how the jobs end.
# Usage: scripts/probe_rerun.sh [WSM_BINARY]   Needs: python3 (standard library only).
set -euo pipefail
wsm=${1:-target/release/wsm}
work=$(mktemp -d)
MAX_CONNECTIONS=${MAX_CONNECTIONS:-200}
"$wsm" serve --addr 127.0.0.1:0 --db "$work/probe.db" --workers 1 --threads-per-job 1 \
  --max-budget 200 --max-connections "$MAX_CONNECTIONS" --header-timeout 5 --body-timeout 5 \
  --store-timeout 2 > "$work/serve.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 1 100); do grep -q 'http://' "$work/serve.log" && break; sleep 0.1; done
addr=$(grep -o 'http://[0-9.:]*' "$work/serve.log" | head -1 | sed 's|http://||')
ulimit -n 4096 2>/dev/null || true
timeout 150 python3 - "$addr" "$work/probe.db" "$(dirname "$0")/../tests/data/hostile_corpus.json" \
  "$MAX_CONNECTIONS" <<'EOF'
import http.client, json, socket, sqlite3, statistics, sys, threading, time

addr, db, corpus_path, cap = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
host, port = addr.split(":")
port = int(port)

def request(method, path, body=None, timeout=30):
    c = http.client.HTTPConnection(host, port, timeout=timeout)
    headers = {"Content-Type": "application/json"} if body is not None else {}
    c.request(method, path, body=None if body is None else json.dumps(body), headers=headers)
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, data

def jbody(data):
    try:
        return json.loads(data)
    except Exception:
        return {}

# 1. Hostile inputs.
status, scene = request("GET", "/v1/examples/block-on-base")
scene = json.loads(scene)
def leaves(v, at=""):
    if isinstance(v, dict):
        for k, x in v.items():
            yield from leaves(x, f"{at}/{k}")
    elif isinstance(v, list) and v:
        for i, x in enumerate(v):
            yield from leaves(x, f"{at}/{i}")
    else:
        yield at
def put(doc, pointer, value):
    doc = json.loads(json.dumps(doc))
    parts = pointer.split("/")[1:]
    target = doc
    for p in parts[:-1]:
        target = target[int(p)] if isinstance(target, list) else target[p]
    last = parts[-1]
    if isinstance(target, list):
        target[int(last)] = value
    else:
        target[last] = value
    return doc
hostile = [1e308, -1.0, 0, "x" * 300, None, {}]
tally = {"requests": 0, "2xx": 0, "4xx_named": 0, "4xx_unnamed": 0, "422_unnamed": 0, "5xx": 0}
def count(status, data):
    tally["requests"] += 1
    if status < 300:
        tally["2xx"] += 1
    elif status >= 500:
        tally["5xx"] += 1
    elif jbody(data).get("path"):
        tally["4xx_named"] += 1
    else:
        tally["4xx_unnamed"] += 1
        if status == 422:
            tally["422_unnamed"] += 1
start = time.time()
for pointer in list(leaves(scene)):
    for value in hostile:
        count(*request("POST", "/v1/solve", {"scene": put(scene, pointer, value)}))
for case in json.load(open(corpus_path)):
    body = case["body"]
    c = http.client.HTTPConnection(host, port, timeout=30)
    raw = body if isinstance(body, str) else json.dumps(body)
    c.request("POST", case["path"], body=raw.encode(), headers={"Content-Type": "application/json"})
    r = c.getresponse(); count(r.status, r.read()); c.close()
for q in ["/v1/jobs?limit=abc", "/v1/jobs?limit=100000", "/v1/jobs?state=zz", "/v1/jobs?offset=-1"]:
    count(*request("GET", q))
print(f"hostile: {tally} in {time.time() - start:.1f} s")

# 2. Load: mixed GETs while a job runs.
status, data = request("POST", "/v1/jobs", {"example": "tunnel-fault",
    "settings": {"budget": 200, "criteria": ["phi3"], "derivatives": False}})
job = jbody(data).get("id")
paths = [f"/v1/jobs/{job}", "/v1/jobs?limit=20", "/healthz", f"/v1/jobs/{job}/evaluations?limit=20"]
latencies, errors, stop = [], [0], time.time() + float(__import__("os").environ.get("LOAD_SECONDS", "10"))
lock = threading.Lock()
def load(k):
    c = http.client.HTTPConnection(host, port, timeout=10)
    i = k
    while time.time() < stop:
        t = time.perf_counter()
        try:
            c.request("GET", paths[i % len(paths)]); r = c.getresponse(); r.read()
            ok = r.status == 200
        except Exception:
            ok = False; c.close(); c = http.client.HTTPConnection(host, port, timeout=10)
        with lock:
            latencies.append(time.perf_counter() - t)
            errors[0] += 0 if ok else 1
        i += 1
threads = [threading.Thread(target=load, args=(k,)) for k in range(8)]
t0 = time.time()
[t.start() for t in threads]; [t.join() for t in threads]
q = statistics.quantiles(latencies, n=100)
print(f"load: {len(latencies)} requests in {time.time() - t0:.1f} s ({len(latencies) / (time.time() - t0):.0f}/s), "
      f"p50 {q[49] * 1e3:.1f} ms, p99 {q[98] * 1e3:.1f} ms, errors {errors[0]}")
request("POST", f"/v1/jobs/{job}/cancel")

# 3. Idle connections.
idle = []
for _ in range(min(2000, cap + 1800)):
    try:
        idle.append(socket.create_connection((host, port), timeout=2))
    except OSError:
        break
def health():
    t = time.perf_counter()
    try:
        s, _ = request("GET", "/healthz", timeout=5)
    except Exception as e:
        s = type(e).__name__
    return s, (time.perf_counter() - t) * 1e3
answers = [health() for _ in range(5)]
print(f"idle: {len(idle)} idle connections (cap {cap}); /healthz meanwhile: "
      + ", ".join(f"{s} in {ms:.0f} ms" for s, ms in answers))
time.sleep(6)
s, ms = health()
closed = 0
for sock in idle:
    sock.settimeout(0.05)
    try:
        closed += 1 if sock.recv(1024) is not None else 0
    except (ConnectionResetError, BrokenPipeError):
        closed += 1
    except OSError:
        pass
    sock.close()
print(f"idle: after the header timeout /healthz {s} in {ms:.0f} ms; {closed} of {len(idle)} closed by the server")

# 4. Slow clients.
sock = socket.create_connection((host, port)); sock.sendall(b"GET /healthz HTT"); t = time.time()
sock.settimeout(20)
try:
    sock.recv(1024)
except OSError:
    pass
print(f"slow: a half-sent request line closed after {time.time() - t:.1f} s")
sock = socket.create_connection((host, port))
sock.sendall(b"POST /v1/solve HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{")
t = time.time(); sock.settimeout(20); reply = sock.recv(200).split(b"\r\n")[0]
print(f"slow: a stalled body answered {reply.decode()} after {time.time() - t:.1f} s")
sock = socket.create_connection((host, port)); t = time.time()
sock.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 1000000000000\r\n\r\n{}")
sock.settimeout(20); reply = sock.recv(200).split(b"\r\n")[0]
print(f"slow: Content-Length 10^12 answered {reply.decode()} after {(time.time() - t) * 1e3:.0f} ms")

# 5. Store outage: the write lock held by another connection for OUTAGE seconds.
outage = 8
jobs = [jbody(request("POST", "/v1/jobs", {"example": "block-on-base",
        "settings": {"budget": 30, "criteria": ["phi3"], "derivatives": False, "seed": k}})[1]).get("id") for k in range(2)]
hold = sqlite3.connect(db, timeout=1, isolation_level=None)
hold.execute("BEGIN EXCLUSIVE")
t0 = time.time(); timeline, submissions = [], {}
while time.time() - t0 < outage:
    timeline.append((round(time.time() - t0, 1), health()[0]))
    s, data = request("POST", "/v1/jobs", {"example": "block-on-base", "settings": {"budget": 4}})
    submissions[s] = submissions.get(s, 0) + 1
    time.sleep(0.5)
hold.execute("ROLLBACK"); hold.close()
t1 = time.time(); recovered = None
while time.time() - t1 < 15:
    if health()[0] == 200:
        recovered = time.time() - t1; break
    time.sleep(0.2)
after = {}
for k in range(8):
    s, data = request("POST", "/v1/jobs", {"example": "block-on-base", "settings": {"budget": 4, "seed": 100 + k}})
    after[s] = after.get(s, 0) + 1
    if s == 202:
        jobs.append(jbody(data)["id"])
degraded = [t for t, s in timeline if s == 503]
print(f"outage: /healthz 503 from {degraded[0] if degraded else None} s of a {outage} s lock; "
      f"ok again {recovered:.1f} s after it was released" if recovered is not None else "outage: never recovered")
print(f"outage: submissions during it {submissions}, after it {after}")
deadline = time.time() + 60
states = {}
for job in [j for j in jobs if j]:
    while time.time() < deadline:
        st = jbody(request("GET", f"/v1/jobs/{job}")[1]).get("state")
        if st in ("succeeded", "failed", "cancelled"):
            break
        time.sleep(0.2)
    states[st] = states.get(st, 0) + 1
print(f"outage: jobs accepted around it ended {states}")
EOF
