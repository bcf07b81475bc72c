"""The worst scenario of the tunnel with a fault, from Python: a table of the extrema and a
figure of how far each criterion moves over the box of uncertain data.

    python examples/python/tunnel_worst.py [--budget N] [--out DIR]
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import wsm  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=400, help="inner solves at most")
    parser.add_argument("--out", type=Path, default=Path("."), help="where the figure goes")
    args = parser.parse_args()

    scene = wsm.example("tunnel-fault")
    nominal = wsm.solve(scene, fields=False).criteria
    result = wsm.worst(scene, budget=args.budget, seed=1)

    print(result)  # the run's summary, as `wsm worst` prints it on stderr
    table = result.extrema[["criterion", "sense", "value", "status"]].copy()
    table["nominal"] = [nominal[c] for c in table["criterion"]]
    table["change %"] = 100 * (table["value"] / table["nominal"] - 1)
    print(table.to_string(index=False))

    # Each criterion's best and worst relative to its nominal value.
    fig, ax = plt.subplots(figsize=(6, 3.5))
    names = list(dict.fromkeys(table["criterion"]))
    for i, name in enumerate(names):
        rows = table[table["criterion"] == name]
        low = rows[rows["sense"] == "min"]["change %"].iloc[0]
        high = rows[rows["sense"] == "max"]["change %"].iloc[0]
        ax.plot([i, i], [low, high], color="tab:red", lw=6, solid_capstyle="butt")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(names)), names)
    ax.set_ylabel("best … worst vs nominal [%]")
    ax.set_title(f"{scene['name']}: {result.outcome['evaluations']} solves")
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    figure = args.out / "tunnel_worst.png"
    fig.savefig(figure, dpi=120)
    print(f"figure: {figure}")


if __name__ == "__main__":
    main()
