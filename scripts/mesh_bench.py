#!/usr/bin/env python3
"""Side-by-side benchmark of wsm's built-in mesher and Shewchuk's Triangle (PyPI `triangle`).

Meshes each case with Triangle (switches pq28a<A>, A = sqrt(3)/4 h^2, the area of an
equilateral triangle of side h) and right after with wsm (the `mesh_bench` example on that case
alone, h = mesh.max_size bounds the longest edge), so that both timings of a case see the same
machine load, and prints a Markdown table: triangle counts, minimum angle, share of triangles
below 30 degrees, median time of `--runs` runs (default 3), and the load average before and
after.

Usage (Triangle is only a benchmark peer, never a dependency of wsm):
    python3 -m venv /tmp/meshvenv && /tmp/meshvenv/bin/pip install triangle numpy
    cargo build --release --example mesh_bench
    /tmp/meshvenv/bin/python scripts/mesh_bench.py [--quick] [--runs N] [--only TEXT]
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import triangle


def arc(r, t0, t1, n):
    return [[r * math.cos(t0 + (t1 - t0) * i / (n - 1)), r * math.sin(t0 + (t1 - t0) * i / (n - 1))]
            for i in range(n)]


def circle(c, r, n):
    return [[c[0] + r * math.cos(2 * math.pi * i / n), c[1] + r * math.sin(2 * math.pi * i / n)]
            for i in range(n)]


def star(spikes, r_in, r_out):
    return [[(r_out if i % 2 == 0 else r_in) * math.cos(math.pi * i / spikes),
             (r_out if i % 2 == 0 else r_in) * math.sin(math.pi * i / spikes)]
            for i in range(2 * spikes)]


def comb(teeth, w, g, length, spine):
    pts = []
    for i in range(teeth):
        x = i * (w + g)
        if i > 0:
            pts.append([x, 0.0])
        pts.append([x, -length])
        pts.append([x + w, -length])
        if i + 1 < teeth:
            pts.append([x + w, 0.0])
    right = teeth * w + (teeth - 1) * g
    return pts + [[right, spine], [0.0, spine]]


def quarter(a, b, n, exact_ends):
    outer, inner = arc(b, 0, math.pi / 2, n), arc(a, 0, math.pi / 2, n)
    if exact_ends:
        outer[-1], inner[-1] = [0.0, b], [0.0, a]
    return outer + inner[::-1]


def cases(quick):
    out = []
    for (a, b, n, h, exact) in [(0.2, 0.5, 97, 0.006, True), (0.2, 0.5, 97, 0.003, True),
                                (0.2, 0.5, 33, 0.006, True), (0.2, 0.5, 33, 0.02, True),
                                (0.2, 0.5, 49, 0.02, False), (0.1, 0.2, 33, 0.008, True)]:
        out.append((f"quarter cylinder {a}/{b} n={n} h={h}", quarter(a, b, n, exact), [], h))
    for n in [8, 64, 400]:
        for h in [0.1, 0.02]:
            out.append((f"annulus n={n} h={h}", circle([0, 0], 1.0, n), [circle([0, 0], 0.4, n // 2 + 3)], h))
    plate = [[0, 0], [4, 0], [4, 3], [0, 3]]
    holes = [circle([1, 1], 0.5, 40), [[2.5, 0.5], [3.5, 0.5], [3.5, 1.0], [2.5, 1.0]],
             circle([2, 2.2], 0.3, 12), [[0.5, 2.0], [1.5, 2.0], [1.5, 2.004], [0.5, 2.004]]]
    out.append(("plate with 4 holes h=0.05", plate, holes, 0.05))
    out.append(("star 12 spikes h=0.05", star(12, 0.2, 1.0), [], 0.05))
    out.append(("comb 10 teeth, gaps 1e-3, h=0.02", comb(10, 0.02, 0.001, 1.0, 0.1), [], 0.02))
    out.append(("strip 1 x 1e-3 h=0.1", [[0, 0], [1, 0], [1, 0.001], [0, 0.001]], [], 0.1))
    # About 1e5 triangles (the speed target) and 4e5.
    sizes = [0.0066] if quick else [0.0066, 0.0033]
    for h in sizes:
        out.append((f"plate with 4 holes h={h}", plate, holes, h * 3))
        out.append((f"quarter cylinder 0.2/0.5 n=97 h={h / 3:.4f}", quarter(0.2, 0.5, 97, True), [], h / 3))
    return out


def scene(poly, holes, h):
    return {"version": 1,
            "bodies": [{"name": "b", "zones": [{"name": "z", "material": "m", "polygon": poly, "holes": holes}]}],
            "materials": {"m": {"E": 1.0, "nu": 0.3}},
            "mesh": {"max_size": h, "min_angle": 28.0}}


def run_triangle(poly, holes, h, runs=3):
    verts, segs, hole_pts = [], [], []
    for ring in [poly] + holes:
        base = len(verts)
        verts += ring
        segs += [[base + i, base + (i + 1) % len(ring)] for i in range(len(ring))]
    for ring in holes:
        hole_pts.append(np.mean(np.array(ring), axis=0).tolist())
    data = {"vertices": np.array(verts), "segments": np.array(segs)}
    if hole_pts:
        data["holes"] = np.array(hole_pts)
    area = math.sqrt(3) / 4 * h * h
    times, res = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        res = triangle.triangulate(data, f"pq28a{area:.15f}Q")
        times.append(time.perf_counter() - t0)
    p, t = res["vertices"], res["triangles"]
    mins = []
    for tri in t:
        q = p[tri]
        ang = []
        for k in range(3):
            u, v = q[(k + 1) % 3] - q[k], q[(k + 2) % 3] - q[k]
            ang.append(math.degrees(math.atan2(abs(u[0] * v[1] - u[1] * v[0]), u @ v)))
        mins.append(min(ang))
    mins = np.array(mins)
    return {"triangles": len(t), "min_angle": float(mins.min()),
            "below_30": int((mins < 30).sum()), "seconds": sorted(times)[len(times) // 2]}


def run_wsm(name, poly, holes, h, runs):
    exe = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "target", "release", "examples",
                       "mesh_bench")
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump([{"name": name, "scene": scene(poly, holes, h)}], f)
    try:
        out = subprocess.run([exe, f.name, str(runs)], capture_output=True, text=True, check=True).stdout
    finally:
        os.unlink(f.name)
    return json.loads(out.splitlines()[0])


def arg(flag, default):
    return sys.argv[sys.argv.index(flag) + 1] if flag in sys.argv else default


def main():
    runs = int(arg("--runs", "3"))
    only = arg("--only", "")
    cs = [c for c in cases("--quick" in sys.argv) if only in c[0]]
    print(f"load average before: {os.getloadavg()[0]:.2f}; {runs} runs per case, medians")
    print()
    print("| case | Triangle: triangles | min angle | < 30° | time | wsm: triangles | min angle | < 30° | time "
          "| time ratio | per-triangle ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for (n, p, hs, h) in cs:
        t = run_triangle(p, hs, h, runs)
        w = run_wsm(n, p, hs, h, runs)
        if "error" in w:
            print(f"| {n} | {t['triangles']} | {t['min_angle']:.1f}° | {100 * t['below_30'] / t['triangles']:.0f} % "
                  f"| {1e3 * t['seconds']:.1f} ms | FAILED: {w['error']} | | | | | |")
            continue
        print(f"| {n} | {t['triangles']} | {t['min_angle']:.1f}° | {100 * t['below_30'] / t['triangles']:.0f} % "
              f"| {1e3 * t['seconds']:.1f} ms | {w['triangles']} | {w['min_angle']:.1f}° "
              f"| {100 * w['below_30'] / w['triangles']:.0f} % | {1e3 * w['seconds']:.1f} ms "
              f"| {w['seconds'] / t['seconds']:.1f}× "
              f"| {(w['seconds'] / w['triangles']) / (t['seconds'] / t['triangles']):.1f}× |", flush=True)
    print()
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
