"""Scenes as plain dicts: the bundled examples, scene files, and the JSON text the engine reads."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Union

from . import _native
from ._errors import BadInputError, translated

Scene = Union[dict, str, os.PathLike]


def examples() -> list[str]:
    """The names of the bundled example scenes."""
    return list(_native.example_names())


@translated
def example(name: str) -> dict:
    """The scene of a bundled example, as a dict (``wsm.examples()`` lists them)."""
    return json.loads(_native.example(name))


@translated
def load(path: str | os.PathLike) -> dict:
    """Read and check a scene file as ``wsm solve FILE`` does (repeated keys, fields, physics):
    a relative ``mesh.gmsh_file`` is made absolute from the file's directory."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise BadInputError(f"{path}: {e.strerror or e}", "io", None, 5) from None
    _native.check_scene(text)
    scene = json.loads(text)
    mesh = scene.get("mesh") if isinstance(scene, dict) else None
    if isinstance(mesh, dict) and isinstance(mesh.get("gmsh_file"), str):
        gmsh = Path(mesh["gmsh_file"])
        if not gmsh.is_absolute():
            mesh["gmsh_file"] = str((path.parent / gmsh).resolve())
    return scene


def scene_text(scene: Any) -> str:
    """The JSON text of a scene given as a dict, a JSON string or a path to a scene file."""
    if isinstance(scene, dict):
        return json.dumps(scene)
    if isinstance(scene, os.PathLike):
        return json.dumps(load(scene))
    if isinstance(scene, str):
        if scene.lstrip().startswith("{"):
            return scene
        return json.dumps(load(scene))
    raise TypeError(f"a scene is a dict, JSON text or a file path, not {type(scene).__name__}")


def request_json(**settings: Any) -> str:
    """The JSON of a request, leaving out the settings that are None (they take the scene's)."""
    return json.dumps({k: v for k, v in settings.items() if v is not None})
