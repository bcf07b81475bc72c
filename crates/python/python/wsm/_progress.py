"""Progress of a run on the terminal: a tqdm bar when tqdm is installed, else nothing."""

from __future__ import annotations

import json


class Bar:
    """Turns the engine's progress events (JSON) into a tqdm bar of evaluations out of the
    budget, with the phase and the best maximum so far; a no-op without tqdm or when off."""

    def __init__(self, enabled: bool, total: int | None = None, unit: str = "solve"):
        self._bar = None
        if enabled:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                return
            self._bar = tqdm(total=total, unit=unit, dynamic_ncols=True)

    def event(self, text: str) -> None:
        """One progress event from the engine (its JSON)."""
        if self._bar is None:
            return
        event = json.loads(text)
        self.update(event["evaluations"], event.get("budget"), event.get("phase"), event.get("best", []))

    def update(self, done: int, total: int | None, phase: str | None, best: list) -> None:
        """Set the bar: `done` of `total`, in `phase`, with the best values so far."""
        if self._bar is None:
            return
        if total and self._bar.total != total:
            self._bar.total = total
        self._bar.n = done
        maxima = [f"{b['criterion']} {b['value']:.4g}" for b in best if b.get("sense") == "max" and b.get("value") is not None]
        self._bar.set_postfix_str(" ".join(filter(None, [phase, ", ".join(maxima)])), refresh=False)
        self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
