"""Results as Python objects: a state solve (`Solution`) and a worst-scenario run
(`WorstResult`), from the same JSON the command line prints."""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd


class Solution:
    """One state solve. `summary` is the dict ``wsm solve`` prints; `criteria` the criteria
    defined for the scene (Φ1–Φ6 by name); `fields` the mesh and fields as NumPy arrays;
    `contact` one row per contact node pair; `profiles` each contact zone's profile against arc
    length (displacement jumps, tractions, state; design §5.8). `write_vtu`, `to_meshio` and `to_pyvista` give the
    VTU document ``wsm solve --vtu`` writes (README "Results in ParaView"): the stress tensor,
    von Mises and principal stresses, zone and body ids, the contact zones as line cells."""

    def __init__(self, output: dict, vtu: str | None = None, vtu_loader: Callable[[], str] | None = None):
        self.summary: dict = output["summary"]
        self.criteria: dict[str, float] = {
            k: v for k, v in self.summary["criteria"].items() if v is not None
        }
        raw = output.get("fields")
        self.fields: dict[str, np.ndarray] = _field_arrays(raw) if raw else {}
        self.contact: pd.DataFrame = _contact_frame(raw["contact"] if raw else [])
        self.profiles: pd.DataFrame = _profile_frame(raw.get("contact_profiles", []) if raw else [])
        self.warnings: list[dict] = list(self.summary.get("report", {}).get("warnings", []))
        self._vtu = vtu
        self._vtu_loader = vtu_loader

    def __repr__(self) -> str:
        values = ", ".join(f"{k}={v:.6g}" for k, v in self.criteria.items())
        mesh = self.summary["mesh"]
        return f"<wsm.Solution {self.summary['scene']!r}: {mesh['nodes']} nodes; {values}>"

    @property
    def vtu(self) -> str:
        """The VTU document (XML with base64 binary arrays)."""
        if self._vtu is None and self._vtu_loader is not None:
            self._vtu = self._vtu_loader()
        if self._vtu is None:
            raise ValueError(
                "this solution has no VTU: solve with fields=True (a server's synchronous solve "
                "returns none; a job's fields do)"
            )
        return self._vtu

    def write_vtu(self, path: str | os.PathLike) -> Path:
        """Write the VTU file (open it in ParaView); its path."""
        path = Path(path)
        path.write_text(self.vtu, encoding="utf-8")
        return path

    def to_meshio(self):
        """The VTU as a `meshio.Mesh`: triangles and contact lines, point, cell and field data."""
        import meshio

        with tempfile.TemporaryDirectory() as tmp:
            return meshio.read(self.write_vtu(Path(tmp) / "solution.vtu"))

    def to_pyvista(self):
        """The VTU as a PyVista unstructured grid (needs pyvista)."""
        import pyvista

        with tempfile.TemporaryDirectory() as tmp:
            return pyvista.read(self.write_vtu(Path(tmp) / "solution.vtu"))


def _field_arrays(raw: dict) -> dict[str, np.ndarray]:
    arrays = {
        "nodes": np.asarray(raw["nodes"], dtype=float).reshape(-1, 2),
        "triangles": np.asarray(raw["triangles"], dtype=np.int64).reshape(-1, 3),
        "triangle_zone": np.asarray(raw["triangle_zone"], dtype=np.int64),
    }
    if raw.get("displacement"):
        arrays["displacement"] = np.asarray(raw["displacement"], dtype=float).reshape(-1, 2)
    if raw.get("temperature") is not None:
        arrays["temperature"] = np.asarray(raw["temperature"], dtype=float)
    if raw.get("stress"):
        arrays["stress"] = np.asarray(raw["stress"], dtype=float).reshape(-1, 4)
        arrays["i2_squared"] = np.asarray(raw["i2_squared"], dtype=float)
        arrays["von_mises"] = np.asarray(raw["von_mises"], dtype=float)
        arrays["principal_stress"] = np.asarray(raw["principal_stress"], dtype=float).reshape(-1, 3)
        arrays["principal_direction"] = np.asarray(raw["principal_direction"], dtype=float).reshape(-1, 2)
    return arrays


_PROFILE_COLUMNS = ["zone", "arc_length", "x", "y", "normal_jump", "tangential_jump", "pressure", "shear", "state"]


def _profile_frame(profiles: list[dict]) -> pd.DataFrame:
    rows = [
        {
            "zone": p["zone"],
            "arc_length": s,
            "x": xy[0],
            "y": xy[1],
            "normal_jump": nj,
            "tangential_jump": tj,
            "pressure": pr,
            "shear": sh,
            "state": st,
        }
        for p in profiles
        for s, xy, nj, tj, pr, sh, st in zip(
            p["arc_length"], p["position"], p["normal_jump"], p["tangential_jump"], p["pressure"], p["shear"], p["state"]
        )
    ]
    return pd.DataFrame(rows, columns=_PROFILE_COLUMNS)


_CONTACT_COLUMNS = ["zone", "x", "y", "pressure", "shear", "gap", "slip", "bound", "state"]


def _contact_frame(nodes: list[dict]) -> pd.DataFrame:
    rows = [
        {
            "zone": n["zone"],
            "x": n["position"][0],
            "y": n["position"][1],
            **{k: n[k] for k in ("pressure", "shear", "gap", "slip", "bound", "state")},
        }
        for n in nodes
    ]
    return pd.DataFrame(rows, columns=_CONTACT_COLUMNS)


class WorstResult:
    """A worst-scenario run. `json` is exactly what ``wsm worst`` prints; `outcome` the full
    outcome (with the convergence histories, as ``--out`` writes it); `extrema` one row per
    criterion and sense with the value, its status and the data; `evaluations` one row per
    evaluation with the columns of ``wsm worst --table``; `warnings` the run's warnings, each a
    dict with ``kind``, ``subject`` and ``message``."""

    def __init__(self, outcome: dict, printed: str, table: str | None, summary: str | None = None):
        self.outcome = outcome
        self.json = printed
        self.warnings: list[dict] = list(outcome.get("warnings", []))
        self.status: str = outcome["status"]
        self.parameters = pd.DataFrame(
            [
                {"name": p["name"], "field": p["field"], "lo": p["interval"][0], "hi": p["interval"][1]}
                for p in outcome["parameters"]
            ],
            columns=["name", "field", "lo", "hi"],
        )
        self.extrema = _extrema_frame(outcome)
        self.evaluations = (
            pd.read_csv(io.StringIO(table)) if table else pd.DataFrame()
        )
        self._summary = summary

    def __repr__(self) -> str:
        return f"<wsm.WorstResult {self.outcome['scene']!r}: {self.status}, {self.outcome['evaluations']} evaluations>"

    def __str__(self) -> str:
        return self._summary or self.extrema.to_string(index=False)

    def extremum(self, criterion: str, sense: str = "max") -> dict:
        """The outcome's entry of one criterion's worst (`max`) or best (`min`) scenario."""
        for c in self.outcome["criteria"]:
            if c["criterion"] == criterion:
                return c["worst" if sense == "max" else "best"]
        names = [c["criterion"] for c in self.outcome["criteria"]]
        raise KeyError(f"{criterion!r} is not a criterion of this run ({', '.join(names)})")


def _extrema_frame(outcome: dict) -> pd.DataFrame:
    names = [p["name"] for p in outcome["parameters"]]
    rows = []
    for c in outcome["criteria"]:
        for key in ("worst", "best"):
            e = c[key]
            row: dict[str, Any] = {
                "criterion": c["criterion"],
                "sense": e["sense"],
                "value": e.get("value"),
                "status": e.get("status"),
                "region": e.get("region"),
            }
            point = e.get("point") or [None] * len(names)
            row.update(zip(names, point))
            rows.append(row)
    return pd.DataFrame(rows, columns=["criterion", "sense", "value", "status", "region", *names])
