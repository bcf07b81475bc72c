"""Global importance of the tunnel's uncertain data: SALib's Sobol indices of each criterion,
computed on `wsm.Evaluator` (one solve per sample point, batches solved in parallel).

    python examples/python/sobol_importance.py [--samples N]   (N a power of 2)
"""

import argparse

import numpy as np
import pandas as pd
from SALib.analyze import sobol
from SALib.sample import sobol as sobol_sample

import wsm


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=256, help="Sobol base samples (power of 2)")
    args = parser.parse_args()

    ev = wsm.Evaluator(wsm.example("tunnel-fault"), derivatives=False)
    problem = ev.salib_problem()
    x = sobol_sample.sample(problem, args.samples, calc_second_order=False, seed=1)
    print(f"{len(x)} points × {len(ev.criteria)} criteria")
    answers = ev(x)
    if any(answers.errors):
        raise SystemExit(f"failed points: {[e for e in answers.errors if e][:3]}")

    rows = []
    for j, criterion in enumerate(ev.criteria):
        indices = sobol.analyze(problem, answers.values[:, j], calc_second_order=False, seed=1)
        for name, s1, st in zip(ev.names, indices["S1"], indices["ST"]):
            rows.append({"criterion": criterion, "datum": name, "S1": s1, "ST": st})
    table = pd.DataFrame(rows)
    print(table.to_string(index=False, float_format=lambda v: f"{v:8.3f}"))
    assert np.isfinite(table[["S1", "ST"]].to_numpy()).all()


if __name__ == "__main__":
    main()
