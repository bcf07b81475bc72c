"""Errors of the engine as Python exceptions: every one is a `WsmError` carrying the kind, the
JSON path of the field it names (`field`) and the exit code `wsm` gives the same error."""

from __future__ import annotations

import functools

from . import _native


class WsmError(Exception):
    """An error of wsm. `kind` is one of bad_input, not_found, unsolvable, solver, io, cancelled;
    `field` the JSON path of the offending field (e.g. ``bodies[0].zones[1].material``) where
    there is one; `exit_code` what the command line exits with (2–6)."""

    def __init__(self, message: str, kind: str = "io", field: str | None = None, exit_code: int = 5):
        super().__init__(message)
        self.message = message
        self.kind = kind
        self.field = field
        self.exit_code = exit_code


class BadInputError(WsmError, ValueError):
    """The input is wrong (a scene field, a setting, an unknown example); `field` names it."""


class UnsolvableError(WsmError):
    """The input is well formed but the physics has no solution (a body cannot be balanced)."""


class SolverError(WsmError, RuntimeError):
    """A solver or the search failed on valid input."""


class CancelledError(WsmError):
    """The work was cancelled before it had a result."""


_BY_KIND = {
    "bad_input": BadInputError,
    "not_found": BadInputError,
    "unsolvable": UnsolvableError,
    "solver": SolverError,
    "cancelled": CancelledError,
    "io": WsmError,
}


def error_of(message: str, kind: str, field: str | None, exit_code: int) -> WsmError:
    """The exception of an engine error (also used for the service's error bodies)."""
    return _BY_KIND.get(kind, WsmError)(message, kind, field, exit_code)


def translated(function):
    """Call `function`, raising the engine's errors as `WsmError`s."""

    @functools.wraps(function)
    def call(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except _native.NativeError as e:
            raise error_of(*e.args) from None

    return call
