"""The criteria as a function of the uncertain data, for the user's own methods (SALib,
OpenTURNS, scipy): `wsm evaluate` in-process, with NumPy in and out."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np
import pandas as pd

from . import _native
from ._errors import BadInputError, translated
from ._scene import request_json, scene_text


@dataclass
class Evaluations:
    """The answers at one point or a batch. For a batch of n points, m criteria and k data:
    `values` (n, m); `gradient_right`, `gradient_left` (n, m, k) the one-sided derivatives
    (equal where the criterion is differentiable; they differ where the contact state changes
    along a datum); `gradient` the right derivative; `max_kkt_residual` (n,); `errors` the reason
    a point has no values (None where it has). A point without values has NaN values. For a
    single point, the leading axis is dropped. Unpacks as ``values, gradient = ev(x)``."""

    values: np.ndarray
    gradient: np.ndarray
    gradient_left: np.ndarray
    gradient_right: np.ndarray
    max_kkt_residual: np.ndarray
    errors: list

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.gradient))


class Evaluator:
    """A scene prepared for evaluations at points of its box: meshed, assembled and solved at
    the nominal data once; each point then costs one solve (with exact derivatives unless
    ``derivatives=False``). Batches are solved in parallel; a point's answer does not depend on
    the batch it came in.

    ``parameters`` is a DataFrame (name, field, lo, hi); ``names``, ``fields``, ``bounds`` (k, 2)
    the same as lists and an array; ``criteria`` the criteria names in answer order;
    ``salib_problem()`` the problem dict SALib wants."""

    @translated
    def __init__(self, scene, criteria: Sequence[str] | None = None, derivatives: bool = True):
        request = request_json(criteria=list(criteria) if criteria is not None else None, derivatives=derivatives)
        self._native = _native.Evaluator(scene_text(scene), request)
        header = json.loads(self._native.header())
        self.parameters = pd.DataFrame(
            [
                {"name": p["name"], "field": p["field"], "lo": p["interval"][0], "hi": p["interval"][1]}
                for p in header["parameters"]
            ],
            columns=["name", "field", "lo", "hi"],
        )
        self.names: list[str] = list(self.parameters["name"])
        self.fields: list[str] = list(self.parameters["field"])
        self.bounds: np.ndarray = self.parameters[["lo", "hi"]].to_numpy(dtype=float).reshape(-1, 2)
        self.criteria: list[str] = list(header["criteria"])
        self.derivatives: bool = bool(header["derivatives"])

    def __repr__(self) -> str:
        return f"<wsm.Evaluator {len(self.names)} data → {', '.join(self.criteria)}>"

    def salib_problem(self) -> dict:
        """``{"num_vars", "names", "bounds"}`` for SALib's samplers and analysers."""
        return {"num_vars": len(self.names), "names": list(self.names), "bounds": self.bounds.tolist()}

    @translated
    def __call__(self, x) -> Evaluations:
        """The criteria (and derivatives) at `x`: one point (k,) or a batch (n, k) of physical
        values in the order of `names`. A point outside the box is answered with an error."""
        points = np.asarray(x, dtype=float)
        single = points.ndim == 1
        if single:
            points = points[None, :]
        k = len(self.names)
        if points.ndim != 2 or points.shape[1] != k:
            raise BadInputError(
                f"points must have shape ({k},) or (n, {k}), got {np.shape(x)}", "bad_input", "x", 2
            )
        answers = json.loads(self._native.answer(points.tolist()))
        result = self._arrays(answers)
        if single:
            return Evaluations(
                result.values[0],
                result.gradient[0],
                result.gradient_left[0],
                result.gradient_right[0],
                result.max_kkt_residual[0],
                result.errors[:1],
            )
        return result

    def _arrays(self, answers: list[dict]) -> Evaluations:
        n, m, k = len(answers), len(self.criteria), len(self.fields)
        values = np.full((n, m), np.nan)
        left = np.full((n, m, k), np.nan)
        right = np.full((n, m, k), np.nan)
        kkt = np.full(n, np.nan)
        errors = []
        for i, a in enumerate(answers):
            errors.append(a.get("error"))
            if a.get("values") is not None:
                values[i] = [a["values"][c] for c in self.criteria]
            for j, c in enumerate(self.criteria):
                by_field = a.get("gradient", {}).get(c)
                if by_field:
                    left[i, j] = [by_field[f]["left"] for f in self.fields]
                    right[i, j] = [by_field[f]["right"] for f in self.fields]
            if a.get("max_kkt_residual") is not None:
                kkt[i] = a["max_kkt_residual"]
        return Evaluations(values, right, left, right, kkt, errors)
