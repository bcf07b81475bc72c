#!/usr/bin/env python3
"""Is a worst-scenario result beaten by any vertex of its box or by random points in it?

    scripts/extrema_check.py WSM SCENE.json RESULT.json [RANDOM=1500] [SEED=1]

Evaluates every vertex (when there are at most 1024) and RANDOM uniform points of the admissible
box independently with `wsm evaluate --no-derivatives`, and compares each criterion's largest and
smallest value with the result's worst and best. Prints one line per criterion; exit 0 when
nothing is more extreme than the reported values (1e-9 relative), 1 otherwise.
"""
import itertools
import json
import random
import subprocess
import sys

wsm, scene, result_path = sys.argv[1:4]
count = int(sys.argv[4]) if len(sys.argv) > 4 else 1500
rng = random.Random(int(sys.argv[5]) if len(sys.argv) > 5 else 1)
result = json.load(open(result_path))
names = [c["criterion"] for c in result["criteria"]]
proc = subprocess.Popen([wsm, "evaluate", scene, "--criteria", ",".join(names), "--no-derivatives"],
                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                        text=True, bufsize=1)
params = json.loads(proc.stdout.readline())["parameters"]
intervals = [p["interval"] for p in params]
points = list(itertools.product(*intervals)) if 2 ** len(params) <= 1024 else []
vertices = len(points)
points += [[lo + rng.random() * (hi - lo) for lo, hi in intervals] for _ in range(count)]
extreme = {}
failed = 0
for x in map(list, points):
    proc.stdin.write(json.dumps(x) + "\n")
    proc.stdin.flush()
    answer = json.loads(proc.stdout.readline())
    if not answer.get("values"):
        failed += 1
        continue
    for c, v in answer["values"].items():
        hi, lo = extreme.get(c, ((v, x), (v, x)))
        extreme[c] = (max(hi, (v, x)), min(lo, (v, x)))
proc.stdin.close()
proc.wait()
print(f"{vertices} vertices and {count} random points ({failed} failed)")
beaten = False
for c in result["criteria"]:
    n = c["criterion"]
    (vmax, xmax), (vmin, xmin) = extreme[n]
    worst, best = c["worst"]["value"], c["best"]["value"]
    tol = 1e-9 * max(abs(vmax), abs(vmin), 1e-300)
    ok_worst, ok_best = worst >= vmax - tol, best <= vmin + tol
    beaten |= not (ok_worst and ok_best)
    print(f"{n}: worst {worst:.9g} vs sampled max {vmax:.9g} {'ok' if ok_worst else 'BEATEN at ' + str(xmax)}; "
          f"best {best:.9g} vs sampled min {vmin:.9g} {'ok' if ok_best else 'BEATEN at ' + str(xmin)}")
sys.exit(1 if beaten else 0)
