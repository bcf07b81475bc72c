#!/usr/bin/env python3
"""Evaluations to the extremum: wsm's worst-scenario search against derivative-free peers.

Scenes: the bundled tunnel (8 uncertain data) and the same with both specific weights and the
left pressure uncertain too (11 data). Objectives: max and min of phi3..phi6. For each it counts
the evaluations needed to come within --tol (relative) of the best known extremum by CMA-ES
(pycma: x0 = centre, sigma0 = 0.3) and scipy's differential evolution (default strategy,
polish=False, tol=atol=0), both on the unit box mapped linearly onto the intervals, --budget
evaluations per run, one run per seed, every call one line to a `wsm evaluate --no-derivatives`
subprocess (all counted, nothing cached); and by `wsm worst` (exact derivatives), whose
evaluations are read in order from its --log and serve all 8 objectives at once (so its count
per objective is conservative). Best known = the most extreme value seen by any run or by a
reference `wsm worst --no-derivatives` run with a large budget (screens all vertices).
Prints one Markdown table per scene; writes raw results to OUT_DIR/results.json.

Usage (cma and scipy are benchmark peers only, never dependencies of wsm):
    python3 -m venv /tmp/peer-venv && /tmp/peer-venv/bin/pip install cma scipy numpy
    cargo build --release
    nice -n 19 /tmp/peer-venv/bin/python scripts/peer_bench.py [--budget 1000] [--seeds 1,2]
        [--scenes 8,11] [--wsm target/release/wsm] [--out-dir /tmp/peer] [--tol 1e-6]
"""
import argparse
import json
import os
import subprocess
import time
import warnings

import numpy as np

warnings.filterwarnings("ignore", message="Could not import matplotlib")
import cma  # noqa: E402
import scipy  # noqa: E402
from scipy.optimize import differential_evolution  # noqa: E402

CRITERIA = ["phi3", "phi4", "phi5", "phi6"]
EXTRA_DATA = [  # the three uncertain data added to the tunnel for the 11-data scene
    {"field": "materials.rock_a.specific_weight", "interval": [22050, 26950]},
    {"field": "materials.rock_b.specific_weight", "interval": [22050, 26950]},
    {"field": "boundary[2].pressure", "interval": [4500000, 5500000]},
]
# scene -> (wsm worst budget, reference --no-derivatives budget)
BUDGETS = {"8": (120, 1000), "11": (400, 6200)}
OBJECTIVES = [(c, sense) for c in CRITERIA for sense in ("max", "min")]


class Budget(Exception):
    """Raised by the objective once a run has used its evaluations."""


class BlackBox:
    """One `wsm evaluate --no-derivatives` subprocess; maps unit-box points to the intervals."""

    def __init__(self, wsm, scene_args):
        cmd = [wsm, "evaluate", *scene_args, "--criteria", ",".join(CRITERIA), "--no-derivatives"]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True, bufsize=1)
        header = json.loads(self.proc.stdout.readline())
        self.lo = np.array([p["interval"][0] for p in header["parameters"]], dtype=float)
        self.hi = np.array([p["interval"][1] for p in header["parameters"]], dtype=float)
        self.errors = []

    def __call__(self, u):
        """Criteria at unit-box point u as a dict, or None if wsm answers with an error."""
        x = np.clip(self.lo + np.asarray(u, dtype=float) * (self.hi - self.lo), self.lo, self.hi)
        self.proc.stdin.write(json.dumps(x.tolist()) + "\n")
        self.proc.stdin.flush()
        answer = json.loads(self.proc.stdout.readline())
        if "error" in answer:
            self.errors.append({"point": x.tolist(), "error": answer["error"]})
            return None
        return answer["values"]

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def objective(box, criterion, sense, budget, trace):
    """A minimiser's objective: counts calls in `trace` (raw values, None for a failure)."""
    sign = -1.0 if sense == "max" else 1.0

    def f(u):
        if len(trace) >= budget:
            raise Budget
        values = box(u)
        trace.append(None if values is None else values[criterion])
        return np.inf if values is None else sign * values[criterion]
    return f


def run_cma(f, k, seed, budget):
    es = cma.CMAEvolutionStrategy([0.5] * k, 0.3, {"bounds": [0, 1], "seed": seed,
                                                   "maxfevals": budget, "verbose": -9})
    try:
        while not es.stop():
            xs = es.ask()
            es.tell(xs, [f(x) for x in xs])
    except Budget:
        pass


def run_de(f, k, seed, budget):
    try:
        differential_evolution(f, [(0, 1)] * k, seed=seed, polish=False, maxiter=10 ** 6,
                               tol=0, atol=0)
    except Budget:
        pass


def wsm_worst(wsm, scene_args, budget, out, log=None, derivatives=True):
    cmd = [wsm, "worst", *scene_args, "--criteria", ",".join(CRITERIA),
           "--budget", str(budget), "--seed", "1", "--out", out]
    cmd += ["--log", log] if log else []
    cmd += [] if derivatives else ["--no-derivatives"]
    for path in (out, log):  # --log refuses to overwrite a log
        if path and os.path.exists(path):
            os.remove(path)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out) as fh:
        return json.load(fh)


def extrema(outcome):
    """(criterion, sense) -> (value, status, certificate verdict) of a `wsm worst` outcome."""
    return {(c["criterion"], r["sense"]):
            (r["value"], r["status"], (r.get("certificate") or {}).get("verdict"))
            for c in outcome["criteria"] for r in (c["worst"], c["best"])}


def log_traces(log):
    """(criterion, sense) -> the criterion's value at each evaluation of a --log, in order."""
    with open(log) as fh:
        lines = [json.loads(line) for line in fh if line.strip()]
    names, evals = lines[0]["criteria"], [l for l in lines[1:] if "point" in l]
    return {(c, s): [None if e["values"] is None else e["values"][names.index(c)] for e in evals]
            for c, s in OBJECTIVES}


def more_extreme(sense, values):
    values = [v for v in values if v is not None and np.isfinite(v)]
    return (max if sense == "max" else min)(values) if values else None


def first_hit(trace, best, tol):
    """1-based index of the first value within tol (relative) of best, or None."""
    return next((i for i, v in enumerate(trace, 1)
                 if v is not None and abs(v - best) <= tol * abs(best)), None)


def bench_scene(name, scene_args, args, seeds):
    """Runs wsm, the reference and the peers on one scene; returns its raw results."""
    wsm_budget, ref_budget = BUDGETS[name]
    t0 = time.time()
    wsm_out = wsm_worst(args.wsm, scene_args, wsm_budget, f"{args.out_dir}/wsm{name}.json",
                        f"{args.out_dir}/wsm{name}.jsonl")
    ref_out = wsm_worst(args.wsm, scene_args, ref_budget, f"{args.out_dir}/ref{name}.json",
                        derivatives=False)
    t_wsm = time.time() - t0
    box, k = BlackBox(args.wsm, scene_args), len(wsm_out["parameters"])
    runs = []
    for criterion, sense in OBJECTIVES:
        for method, run in (("CMA-ES", run_cma), ("DE", run_de)):
            for seed in seeds:
                trace = []
                run(objective(box, criterion, sense, args.budget, trace), k, seed, args.budget)
                runs.append({"criterion": criterion, "sense": sense, "method": method,
                             "seed": seed, "trace": trace})
    box.close()
    return {"scene": name, "k": k, "wsm": wsm_out, "ref": ref_out, "runs": runs,
            "wsm_traces": log_traces(f"{args.out_dir}/wsm{name}.jsonl"), "errors": box.errors,
            "seconds_wsm_and_ref": t_wsm, "seconds_peers": time.time() - t0 - t_wsm}


def summarise(res, tol):
    """Per objective: the best known value and each method's evaluations to reach it."""
    wsm, ref, rows = extrema(res["wsm"]), extrema(res["ref"]), []
    for criterion, sense in OBJECTIVES:
        key = (criterion, sense)
        peers = {f"{r['method']} seed {r['seed']}": r["trace"] for r in res["runs"]
                 if (r["criterion"], r["sense"]) == key}
        traces = {"wsm": res["wsm_traces"][key], **peers}
        best = more_extreme(sense, [wsm[key][0], ref[key][0],
                                    *(v for t in traces.values() for v in t)])
        rows.append({"criterion": criterion, "sense": sense, "best_known": best,
                     "wsm_value": wsm[key][0], "wsm_status": wsm[key][1],
                     "wsm_verdict": wsm[key][2], "ref_value": ref[key][0],
                     "runs": {m: {"hit": first_hit(t, best, tol), "best": more_extreme(sense, t),
                                  "evaluations": len(t)} for m, t in traces.items()}})
    return rows


def cell(run, best):
    """A table cell: evaluations to reach `best`, or the gap left at the end of the run."""
    if run["hit"] is not None:
        return str(run["hit"])
    gap = ("no value" if run["best"] is None
           else f"rel. gap {abs(run['best'] - best) / abs(best):.1e}")
    return f"not reached ({gap}, {run['evaluations']} ev.)"


def markdown(res, seeds):
    """The scene's Markdown table; the better peer is the peer run that reached soonest."""
    cols = [f"{m} seed {s}" for m in ("CMA-ES", "DE") for s in seeds]
    out = [f"### {res['scene']} uncertain data (k = {res['k']}; wsm worst: "
           f"{res['wsm']['evaluations']} evaluations of budget {BUDGETS[res['scene']][0]}, "
           f"status {res['wsm']['status']}; reference --no-derivatives: "
           f"{res['ref']['evaluations']} evaluations)", "",
           "| objective | best known | wsm: evals to 1e-6 (status) | " + " | ".join(cols)
           + " | wsm / better peer |", "|---" * (4 + len(cols)) + "|"]
    for row in res["rows"]:
        runs, best = row["runs"], row["best_known"]
        peer_hits = [runs[c]["hit"] for c in cols if runs[c]["hit"] is not None]
        wsm_hit = runs["wsm"]["hit"]
        ratio = f"{wsm_hit / min(peer_hits):.2f}" if wsm_hit and peer_hits else "–"
        status = row["wsm_status"] + ("" if row["wsm_verdict"] in (None, row["wsm_status"])
                                      else f", {row['wsm_verdict']}")
        out.append(f"| {row['sense']} {row['criterion']} | {best:.10g} | "
                   f"{cell(runs['wsm'], best)} ({status}) | "
                   + " | ".join(cell(runs[c], best) for c in cols) + f" | {ratio} |")
    return "\n".join(out)


def scene_args(name, args):
    if name == "8":
        return ["--example", "tunnel-fault"]
    scene = json.loads(subprocess.run([args.wsm, "example", "tunnel-fault"], check=True,
                                      capture_output=True, text=True).stdout)
    scene["uncertain"] += EXTRA_DATA
    path = f"{args.out_dir}/tunnel11.json"
    with open(path, "w") as fh:
        json.dump(scene, fh, indent=1)
    return [path]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--budget", type=int, default=1000, help="evaluations per peer run")
    p.add_argument("--seeds", default="1,2")
    p.add_argument("--scenes", default="8,11")
    p.add_argument("--wsm", default="target/release/wsm")
    p.add_argument("--out-dir", default="/tmp/peer")
    p.add_argument("--tol", type=float, default=1e-6)
    args = p.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    os.makedirs(args.out_dir, exist_ok=True)
    t0, results = time.time(), []
    print(f"cma {cma.__version__}, scipy {scipy.__version__}, numpy {np.__version__}; "
          f"peer budget {args.budget}, seeds {seeds}, tol {args.tol:g}\n", flush=True)
    for name in args.scenes.split(","):
        res = bench_scene(name, scene_args(name, args), args, seeds)
        res["rows"] = summarise(res, args.tol)
        print(markdown(res, seeds) + "\n")
        res["wsm_traces"] = {f"{s} {c}": t for (c, s), t in res["wsm_traces"].items()}
        results.append(res)
        print(f"wsm + reference: {res['seconds_wsm_and_ref']:.0f} s; peers: "
              f"{res['seconds_peers']:.0f} s; black-box errors: {len(res['errors'])}\n",
              flush=True)
    print(f"total run time: {time.time() - t0:.0f} s")
    with open(f"{args.out_dir}/results.json", "w") as fh:
        json.dump({"versions": {"cma": cma.__version__, "scipy": scipy.__version__,
                                "numpy": np.__version__}, "budget": args.budget, "seeds": seeds,
                   "tol": args.tol, "scenes": results}, fh)


if __name__ == "__main__":
    main()
