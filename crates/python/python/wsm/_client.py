"""A client of `wsm serve` (the REST API of docs/service.md), in the standard library only:
submit a worst-scenario job, wait for it with progress, fetch its result as the same
`WorstResult` as an in-process run, its evaluations and the fields of its worst or best
scenario."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, Sequence

from ._errors import WsmError, error_of
from ._progress import Bar
from ._results import Solution, WorstResult
from ._scene import scene_text

# The service's stable error codes (ErrorBody.error) and the kind of WsmError each becomes.
_KIND_OF_CODE = {
    "malformed_json": "bad_input",
    "invalid_input": "bad_input",
    "too_large": "bad_input",
    "not_found": "not_found",
    "unsolvable": "unsolvable",
    "solver_failure": "solver",
}
_EXIT_CODE = {"bad_input": 2, "not_found": 2, "unsolvable": 3, "solver": 4, "cancelled": 6}
_FINAL = {"succeeded", "failed", "cancelled"}


class Client:
    """`wsm serve` at `url` (e.g. ``http://127.0.0.1:8080``), with the API token when the
    server has one (``WSM_API_TOKEN``)."""

    def __init__(self, url: str, token: str | None = None, timeout: float = 60.0):
        self.url = url.rstrip("/")
        self.token = token
        self.timeout = timeout

    def __repr__(self) -> str:
        return f"<wsm.Client {self.url}>"

    # -- requests ----------------------------------------------------------------------------

    def _request(self, method: str, path: str, body: Any = None, query: dict | None = None) -> bytes:
        url = self.url + path
        if query:
            url += "?" + urllib.parse.urlencode({k: v for k, v in query.items() if v is not None})
        data = None
        headers = {"Accept": "application/json"}
        if body is not None:
            data = body if isinstance(body, bytes) else json.dumps(body).encode()
            headers["Content-Type"] = "application/json"
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        request = urllib.request.Request(url, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return response.read()
        except urllib.error.HTTPError as e:
            raise _service_error(e) from None
        except urllib.error.URLError as e:
            raise WsmError(f"{url}: {e.reason}", "io", None, 5) from None

    def _json(self, method: str, path: str, body: Any = None, query: dict | None = None) -> Any:
        return json.loads(self._request(method, path, body, query))

    # -- jobs --------------------------------------------------------------------------------

    def submit(
        self,
        scene=None,
        *,
        example: str | None = None,
        criteria: Sequence[str] | None = None,
        budget: int | None = None,
        seed: int | None = None,
        **settings: Any,
    ) -> str:
        """Queue a worst-scenario search of `scene` (a dict, JSON text or file) or of a bundled
        `example`; the job's id. Settings left out take the scene's `search` values."""
        if (scene is None) == (example is None):
            raise WsmError("give a scene or example=NAME (not both)", "bad_input", "scene", 2)
        chosen = {"criteria": list(criteria) if criteria is not None else None, "budget": budget, "seed": seed, **settings}
        body: dict[str, Any] = {"settings": {k: v for k, v in chosen.items() if v is not None}}
        if example is not None:
            body["example"] = example
        else:
            body["scene"] = json.loads(scene_text(scene))
        return self._json("POST", "/v1/jobs", body)["id"]

    def status(self, job: str) -> dict:
        """The job's status: state, phase, evaluations, best values so far, warnings …"""
        return self._json("GET", f"/v1/jobs/{job}")

    def cancel(self, job: str) -> dict:
        """Ask the job to stop; it ends `cancelled` with its partial result."""
        return self._json("POST", f"/v1/jobs/{job}/cancel")

    def wait(self, job: str, progress: bool = True, poll: float = 0.5, timeout: float | None = None) -> dict:
        """Wait until the job has finished; its final status. Raises a `WsmError` when it
        failed, `TimeoutError` after `timeout` seconds (the job goes on)."""
        bar = Bar(progress)
        start = time.monotonic()
        try:
            while True:
                status = self.status(job)
                bar.update(status["evaluations"], status["budget"], status["phase"], status.get("best", []))
                if status["state"] in _FINAL:
                    break
                if timeout is not None and time.monotonic() - start > timeout:
                    raise TimeoutError(f"job {job} is still {status['state']} after {timeout} s")
                time.sleep(poll)
        finally:
            bar.close()
        if status["state"] == "failed":
            kind = status.get("error_kind") or "solver"
            raise error_of(status.get("error") or "the job failed", kind, None, _EXIT_CODE.get(kind, 5))
        return status

    def result(self, job: str) -> WorstResult:
        """The finished job's result, with its evaluations (as ``wsm worst --table``)."""
        outcome = self._json("GET", f"/v1/jobs/{job}/result")
        printed = dict(outcome)
        printed["criteria"] = [
            {**c, "worst": {**c["worst"], "history": []}, "best": {**c["best"], "history": []}}
            for c in outcome["criteria"]
        ]
        table = self.evaluations_csv(job)
        return WorstResult(outcome, json.dumps(printed, indent=2), table)

    def evaluations_csv(self, job: str) -> str:
        """Every evaluation of the job as CSV (the columns of ``wsm worst --table``)."""
        return self._request("GET", f"/v1/jobs/{job}/evaluations", query={"format": "csv"}).decode()

    def fields(self, job: str, scenario: str = "worst", criterion: str | None = None) -> Solution:
        """The solve of the job's `worst` or `best` scenario of `criterion` (default: its
        first), with fields."""
        query = {"scenario": scenario, "criterion": criterion}
        output = self._json("GET", f"/v1/jobs/{job}/fields", query=query)
        fetch_vtu = lambda: self._request(  # noqa: E731 — fetched when first used
            "GET", f"/v1/jobs/{job}/fields", query={**query, "format": "vtu"}
        ).decode()
        return Solution(output, vtu_loader=fetch_vtu)

    def worst(self, scene=None, *, progress: bool = True, **settings: Any) -> WorstResult:
        """Submit, wait (a Ctrl-C cancels the job) and fetch the result."""
        job = self.submit(scene, **settings)
        try:
            self.wait(job, progress=progress)
        except KeyboardInterrupt:
            self.cancel(job)
            raise
        return self.result(job)

    def solve(self, scene=None, *, example: str | None = None, solver: str | None = None, fields: bool = True) -> Solution:
        """A synchronous solve on the server (small scenes)."""
        body: dict[str, Any] = {"settings": {k: v for k, v in {"solver": solver, "fields": fields}.items() if v is not None}}
        if example is not None:
            body["example"] = example
        else:
            body["scene"] = json.loads(scene_text(scene))
        return Solution(self._json("POST", "/v1/solve", body))


def _service_error(e: "urllib.error.HTTPError") -> WsmError:
    try:
        body = json.loads(e.read())
        code, detail, path = body.get("error", ""), body.get("detail", str(e)), body.get("path")
    except (ValueError, AttributeError):
        code, detail, path = "", f"HTTP {e.code}: {e.reason}", None
    kind = _KIND_OF_CODE.get(code, "io")
    return error_of(f"{detail} (HTTP {e.code} {code})".strip(), kind, path, _EXIT_CODE.get(kind, 5))
