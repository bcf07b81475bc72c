"""Meshes from Gmsh and meshio into wsm (design §2.5): the committed block-on-base meshes are
what scripts/gmsh_block_on_base.py writes with the pinned gmsh wheel, and a mesh read by meshio
from any of the four MSH formats, given inline (`mesh.inline`), solves like the Gmsh file."""

import json
import subprocess
import sys
from pathlib import Path

import meshio
import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
FORMATS = ["4.1-ascii", "4.1-binary", "2.2-ascii", "2.2-binary"]
ZONES = ["base", "block"]
SEGMENTS = ["bottom", "top", "push", "base_contact", "block_contact"]


def cells_named(mesh: meshio.Mesh, name: str, kind: str) -> list:
    """The cells of type `kind` in the physical group `name`: from meshio's cell sets (MSH 4.1,
    where one curve may carry two names) or its `gmsh:physical` cell data (MSH 2.2, where such a
    curve's lines are written once per name)."""
    if name in mesh.cell_sets:
        groups = zip(mesh.cells, mesh.cell_sets[name])
    else:
        tag = mesh.field_data[name][0]
        groups = ((b, p == tag) for b, p in zip(mesh.cells, mesh.cell_data["gmsh:physical"]))
    return [cell for block, which in groups if block.type == kind for cell in block.data[which].tolist()]


def inline_from_meshio(mesh: meshio.Mesh) -> dict:
    """`mesh.inline` from a meshio mesh whose physical groups are named like the scene's zones
    (triangles) and segments (lines)."""
    triangles, triangle_zones = [], []
    for k, name in enumerate(ZONES):
        cells = cells_named(mesh, name, "triangle")
        triangles += cells
        triangle_zones += [k] * len(cells)
    return {
        "nodes": mesh.points[:, :2].tolist(),
        "triangles": triangles,
        "zones": ZONES,
        "triangle_zones": triangle_zones,
        "segments": {name: cells_named(mesh, name, "line") for name in SEGMENTS},
    }


def test_the_generator_writes_the_committed_meshes(tmp_path):
    subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "gmsh_block_on_base.py"), str(tmp_path)],
        check=True,
        capture_output=True,
    )
    for fmt in FORMATS:
        name = f"block-on-base-{fmt}.msh"
        assert (tmp_path / name).read_bytes() == (DATA / name).read_bytes(), name


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_meshio_mesh_inline_solves_like_the_gmsh_file(fmt, tmp_path, run_wsm):
    scene = json.loads((DATA / "block-on-base-gmsh.json").read_text())
    scene["mesh"] = {"gmsh_file": str(DATA / f"block-on-base-{fmt}.msh")}
    (tmp_path / "gmsh.json").write_text(json.dumps(scene))
    scene["mesh"] = {"inline": inline_from_meshio(meshio.read(DATA / f"block-on-base-{fmt}.msh"))}
    (tmp_path / "inline.json").write_text(json.dumps(scene))
    gmsh = json.loads(run_wsm("solve", tmp_path / "gmsh.json").stdout)
    inline = json.loads(run_wsm("solve", tmp_path / "inline.json").stdout)
    assert inline["mesh"] == gmsh["mesh"]
    assert gmsh["mesh"]["triangles"] == 250 and gmsh["mesh"]["contact_pairs"] == 9
    for name, value in gmsh["criteria"].items():
        if value is not None:
            assert inline["criteria"][name] == pytest.approx(value, rel=1e-12), name


def test_an_inline_mesh_with_a_bad_index_names_its_place(tmp_path, run_wsm):
    scene = json.loads((DATA / "block-on-base-gmsh.json").read_text())
    inline = inline_from_meshio(meshio.read(DATA / "block-on-base-4.1-ascii.msh"))
    inline["triangles"][17] = [0, 1, 100000]
    scene["mesh"] = {"inline": inline}
    (tmp_path / "bad.json").write_text(json.dumps(scene))
    done = run_wsm("solve", tmp_path / "bad.json", check=False)
    assert done.returncode == 2
    assert done.stderr.startswith("error: mesh.inline.triangles[17]: node index 100000"), done.stderr
