"""wsm — worst-scenario analysis of multibody elastic contact, in Python.

The engine runs in-process (the GIL is released while it solves; Ctrl-C cancels a run)::

    import wsm
    scene = wsm.example("tunnel-fault")          # or wsm.load("my-scene.json"): plain dicts
    result = wsm.worst(scene, budget=120)         # the same numbers as `wsm worst`
    print(result.extrema)                         # a DataFrame: criterion, sense, value, data …
    sol = wsm.solve(scene)                        # one state solve, fields as NumPy arrays

`Evaluator` gives the criteria and their exact derivatives at your own points (SALib,
OpenTURNS, scipy); `Client` drives a `wsm serve`. Errors are `WsmError`s naming the field.
"""

from __future__ import annotations

import json
from typing import Sequence

from . import _native
from ._client import Client
from ._errors import (
    BadInputError,
    CancelledError,
    SolverError,
    UnsolvableError,
    WsmError,
    translated,
)
from ._evaluator import Evaluations, Evaluator
from ._mesh import mesh_from_meshio
from ._progress import Bar
from ._results import Solution, WorstResult
from ._scene import example, examples, load, request_json, scene_text

__version__ = _native.__version__

__all__ = [
    "BadInputError",
    "CancelledError",
    "Client",
    "Evaluations",
    "Evaluator",
    "Solution",
    "SolverError",
    "UnsolvableError",
    "WorstResult",
    "WsmError",
    "example",
    "examples",
    "load",
    "mesh_from_meshio",
    "solve",
    "worst",
]


@translated
def solve(scene, solver: str | None = None, fields: bool = True) -> Solution:
    """One state solve of `scene` (a dict, JSON text or a scene file) at its nominal data, as
    ``wsm solve``. `solver`: ``"direct"`` or ``"dd"`` (default: the scene's ``solver.kind``).
    With `fields` (default) the solution carries the mesh and fields."""
    output, vtu = _native.solve(scene_text(scene), request_json(solver=solver, fields=fields))
    return Solution(json.loads(output), vtu=vtu)


@translated
def worst(
    scene,
    criteria: Sequence[str] | None = None,
    budget: int | None = None,
    seed: int | None = None,
    threads: int | None = None,
    log: str | None = None,
    progress: bool = True,
    *,
    resume: str | None = None,
    max_seconds: float | None = None,
    accuracy_refinements: int | None = None,
    target_error: float | None = None,
    derivatives: bool | None = None,
    stop: str | None = None,
) -> WorstResult:
    """The worst and best scenario of each criterion over the scene's admissible box, as
    ``wsm worst`` (same settings, same numbers). Settings left as None take the scene's
    `search` values. `log` writes the JSON-lines evaluation log (``--log``), `resume` continues
    one (``--resume``); `progress` shows a tqdm bar when tqdm is installed. Ctrl-C stops the run
    within one evaluation batch and raises KeyboardInterrupt."""
    request = request_json(
        criteria=list(criteria) if criteria is not None else None,
        budget=budget,
        seed=seed,
        threads=threads,
        max_seconds=max_seconds,
        accuracy_refinements=accuracy_refinements,
        target_error=target_error,
        derivatives=derivatives,
        stop=stop,
    )
    bar = Bar(progress)
    try:
        full, printed, table, summary = _native.worst(
            scene_text(scene),
            request,
            log=None if log is None else str(log),
            resume=None if resume is None else str(resume),
            progress=bar.event if progress else None,
        )
    finally:
        bar.close()
    return WorstResult(json.loads(full), printed, table, summary)
