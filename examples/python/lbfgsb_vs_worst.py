"""scipy's L-BFGS-B on `wsm.Evaluator` (values and exact derivatives) against `wsm.worst`:
a local method from the centre of the box finds a local maximum; wsm's search answers the
global question and says how sure it is.

    python examples/python/lbfgsb_vs_worst.py [--budget N]
"""

import argparse

import numpy as np
import pandas as pd
from scipy.optimize import minimize

import wsm


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=400, help="wsm.worst's inner solves at most")
    args = parser.parse_args()

    scene = wsm.example("tunnel-fault")
    ev = wsm.Evaluator(scene)
    # Work in the unit box: the data differ by orders of magnitude.
    lo, hi = ev.bounds[:, 0], ev.bounds[:, 1]
    physical = lambda z: lo + z * (hi - lo)  # noqa: E731

    result = wsm.worst(scene, budget=args.budget, seed=1, progress=False)
    rows = []
    for j, criterion in enumerate(ev.criteria):
        solves = 0

        def negative(z, j=j):
            nonlocal solves
            solves += 1
            values, gradient = ev(physical(z))
            return -values[j], -gradient[j] * (hi - lo)

        found = minimize(negative, np.full(len(lo), 0.5), jac=True, method="L-BFGS-B", bounds=[(0, 1)] * len(lo))
        worst = result.extremum(criterion, "max")
        rows.append(
            {
                "criterion": criterion,
                "L-BFGS-B max": -found.fun,
                "solves": solves,
                "wsm.worst max": worst["value"],
                "status": worst["status"],
                "wsm ≥ L-BFGS-B": worst["value"] >= -found.fun * (1 - 1e-9),
            }
        )
    table = pd.DataFrame(rows)
    print(table.to_string(index=False))
    print(f"wsm.worst: {result.outcome['evaluations']} solves for all {len(ev.criteria)} criteria, max and min")
    if not table["wsm ≥ L-BFGS-B"].all():
        raise SystemExit("L-BFGS-B found a larger value than wsm.worst")


if __name__ == "__main__":
    main()
