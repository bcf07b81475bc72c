"""Meshes from any format meshio reads, as the scene's inline mesh (README "Meshing: built-in or
Gmsh", `mesh.inline`)."""

from __future__ import annotations

from typing import Mapping

import numpy as np


def mesh_from_meshio(
    mesh,
    zones: Mapping[int, str] | None = None,
    segments: Mapping[int, str] | None = None,
    tag: str | None = None,
) -> dict:
    """The scene's ``mesh.inline`` section from a `meshio.Mesh`: its triangles with their zone
    names and its line cells as named boundary segments. Put the result in a scene as
    ``scene["mesh"] = {"inline": wsm.mesh_from_meshio(m)}``.

    Names come from the mesh's named cell sets (Gmsh's physical groups as meshio reads MSH 4.1,
    where one curve may carry two names — both sides of a contact); without them, or when
    `zones`, `segments` or `tag` is given, from the cells' tags: the ``gmsh:physical`` cell data
    (or `tag`, another integer cell-data key) mapped to names by the field data (``name: [tag,
    dim]``) or by `zones` (tag → zone name, for triangles) and `segments` (tag → segment name,
    for lines), which take precedence. Nodes used by no triangle are left out (meshio keeps
    Gmsh's geometry points); the others are renumbered from 0 in their order."""
    named_sets = {k: v for k, v in (mesh.cell_sets or {}).items() if not k.startswith("gmsh:")}
    if named_sets and zones is None and segments is None and tag is None:
        triangles, triangle_names, lines = _from_cell_sets(mesh, named_sets)
    else:
        triangles, triangle_names, lines = _from_tags(mesh, zones, segments, tag)
    if not triangles:
        raise ValueError("the mesh has no triangles")
    triangles = np.asarray(triangles, dtype=np.int64)
    used = np.unique(triangles)
    renumber = np.full(len(mesh.points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    zone_names = list(dict.fromkeys(triangle_names))
    zone_index = {name: i for i, name in enumerate(zone_names)}
    inline_segments = {}
    for name, cells in lines.items():
        edges = renumber[np.asarray(cells, dtype=np.int64)]
        if (edges < 0).any():
            raise ValueError(f"segment {name!r} has edges on nodes of no triangle")
        inline_segments[name] = edges.tolist()
    return {
        "nodes": np.asarray(mesh.points)[used, :2].astype(float).tolist(),
        "triangles": renumber[triangles].tolist(),
        "zones": zone_names,
        "triangle_zones": [zone_index[n] for n in triangle_names],
        "segments": inline_segments,
    }


def _check_types(mesh) -> None:
    for block in mesh.cells:
        if block.type not in ("triangle", "line", "vertex"):
            raise ValueError(f"cells of type {block.type!r} are not supported (3-node triangles and 2-node lines)")


def _from_cell_sets(mesh, named_sets):
    """Triangles, their zone names and the line cells by segment name, from named cell sets."""
    _check_types(mesh)
    zone_of: dict[tuple[int, int], str] = {}
    lines: dict[str, list] = {}
    for name, per_block in named_sets.items():
        for b, (block, which) in enumerate(zip(mesh.cells, per_block)):
            if which is None or len(which) == 0:
                continue
            if block.type == "triangle":
                for i in np.asarray(which, dtype=np.int64):
                    other = zone_of.setdefault((b, int(i)), name)
                    if other != name:
                        raise ValueError(f"a triangle is in two zones, {other!r} and {name!r}")
            elif block.type == "line":
                lines.setdefault(name, []).extend(np.asarray(block.data)[which].tolist())
    triangles, names = [], []
    for b, block in enumerate(mesh.cells):
        if block.type != "triangle":
            continue
        for i, cell in enumerate(np.asarray(block.data)):
            if (b, i) not in zone_of:
                raise ValueError(f"triangle {i} of cell block {b} is in no named group (its zone)")
            triangles.append(cell)
            names.append(zone_of[(b, i)])
    return triangles, names, lines


def _from_tags(mesh, zones, segments, tag):
    """Triangles, their zone names and the line cells by segment name, from integer cell tags."""
    _check_types(mesh)
    key = tag or ("gmsh:physical" if "gmsh:physical" in mesh.cell_data else None)
    if key is None:
        raise ValueError(
            "the mesh's cells carry no names or tags: give tag= (an integer cell-data key) "
            f"among {sorted(mesh.cell_data)}"
        )
    named = {}
    for name, value in (mesh.field_data or {}).items():
        value = np.asarray(value).ravel()
        if len(value) >= 2:
            named[(int(value[1]), int(value[0]))] = name

    def name_of(dim: int, cell_tag: int, given: Mapping[int, str] | None) -> str | None:
        if given and cell_tag in given:
            return given[cell_tag]
        return named.get((dim, cell_tag))

    triangles, names, lines = [], [], {}
    for block, tags in zip(mesh.cells, mesh.cell_data[key]):
        tags = np.asarray(tags, dtype=np.int64)
        if block.type == "triangle":
            for cell, t in zip(np.asarray(block.data), tags):
                zone = name_of(2, int(t), zones)
                if zone is None:
                    raise ValueError(f"triangle tag {int(t)} has no zone name: give zones={{{int(t)}: 'NAME'}}")
                triangles.append(cell)
                names.append(zone)
        elif block.type == "line":
            for cell, t in zip(np.asarray(block.data), tags):
                segment = name_of(1, int(t), segments)
                if segment is not None:
                    lines.setdefault(segment, []).append(cell)
    return triangles, names, lines
