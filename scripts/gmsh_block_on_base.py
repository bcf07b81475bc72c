"""Writes the Gmsh meshes of the block-on-base contact scene (scenes/block-on-base.json's
geometry) used by the import tests: tests/data/block-on-base-{4.1-ascii,4.1-binary,2.2-ascii,
2.2-binary}.msh, one mesh in four formats; and tests/data/block-on-base-nonmatching.msh (MSH 4.1
ASCII), the two bodies meshed on their own for the mortar import test.

The two bodies share the contact curve y = 0.5, 0.5 <= x <= 1.5 (one Gmsh curve in both
surfaces, so its nodes coincide); the physical names are the scene's zone names ("base",
"block") and segment names ("bottom", "top", "push", "base_contact", "block_contact" — the
contact curve carries both contact names). In the non-matching mesh each body has its own
contact curve, with its own end points: the base's in 8 elements, the block's in 21 (sizes 1 : 2.6
across), so no interior node of one side lies on a node of the other.

    python scripts/gmsh_block_on_base.py [OUT_DIR] [SIZE]     (needs the `gmsh` PyPI package)
"""

import sys
from pathlib import Path

import gmsh

FORMATS = {
    "4.1-ascii": (4.1, 0),
    "4.1-binary": (4.1, 1),
    "2.2-ascii": (2.2, 0),
    "2.2-binary": (2.2, 1),
}


def build(size: float) -> None:
    geo = gmsh.model.geo
    p = {
        xy: geo.addPoint(*xy, 0.0, size)
        for xy in [(0, 0), (2, 0), (2, 0.5), (1.5, 0.5), (0.5, 0.5), (0, 0.5), (1.5, 1), (0.5, 1)]
    }

    def line(a, b):
        return geo.addLine(p[a], p[b])

    bottom = line((0, 0), (2, 0))
    right = line((2, 0), (2, 0.5))
    base_right_top = line((2, 0.5), (1.5, 0.5))
    contact = line((1.5, 0.5), (0.5, 0.5))
    base_left_top = line((0.5, 0.5), (0, 0.5))
    left = line((0, 0.5), (0, 0))
    block_right = line((1.5, 0.5), (1.5, 1))
    top = line((1.5, 1), (0.5, 1))
    push = line((0.5, 1), (0.5, 0.5))
    base = geo.addPlaneSurface(
        [geo.addCurveLoop([bottom, right, base_right_top, contact, base_left_top, left])]
    )
    block = geo.addPlaneSurface([geo.addCurveLoop([-contact, block_right, top, push])])
    geo.synchronize()
    for dim, tags, name in [
        (2, [base], "base"),
        (2, [block], "block"),
        (1, [bottom], "bottom"),
        (1, [top], "top"),
        (1, [push], "push"),
        (1, [contact], "base_contact"),
        (1, [contact], "block_contact"),
    ]:
        gmsh.model.addPhysicalGroup(dim, tags, name=name)
    gmsh.model.mesh.generate(2)


def build_nonmatching(size: float, base_elements: int, block_elements: int) -> None:
    """The same geometry with each body's contact side its own curve (Gmsh keeps the coinciding
    points of the two bodies apart), divided uniformly into the given numbers of elements."""
    geo = gmsh.model.geo

    def points(xys):
        return {xy: geo.addPoint(*xy, 0.0, size) for xy in xys}

    b = points([(0, 0), (2, 0), (2, 0.5), (1.5, 0.5), (0.5, 0.5), (0, 0.5)])
    k = points([(1.5, 0.5), (0.5, 0.5), (1.5, 1), (0.5, 1)])
    bottom = geo.addLine(b[(0, 0)], b[(2, 0)])
    right = geo.addLine(b[(2, 0)], b[(2, 0.5)])
    base_right_top = geo.addLine(b[(2, 0.5)], b[(1.5, 0.5)])
    base_contact = geo.addLine(b[(1.5, 0.5)], b[(0.5, 0.5)])
    base_left_top = geo.addLine(b[(0.5, 0.5)], b[(0, 0.5)])
    left = geo.addLine(b[(0, 0.5)], b[(0, 0)])
    block_contact = geo.addLine(k[(0.5, 0.5)], k[(1.5, 0.5)])
    block_right = geo.addLine(k[(1.5, 0.5)], k[(1.5, 1)])
    top = geo.addLine(k[(1.5, 1)], k[(0.5, 1)])
    push = geo.addLine(k[(0.5, 1)], k[(0.5, 0.5)])
    geo.mesh.setTransfiniteCurve(base_contact, base_elements + 1)
    geo.mesh.setTransfiniteCurve(block_contact, block_elements + 1)
    base = geo.addPlaneSurface(
        [geo.addCurveLoop([bottom, right, base_right_top, base_contact, base_left_top, left])]
    )
    block = geo.addPlaneSurface([geo.addCurveLoop([block_contact, block_right, top, push])])
    geo.synchronize()
    for dim, tags, name in [
        (2, [base], "base"),
        (2, [block], "block"),
        (1, [bottom], "bottom"),
        (1, [top], "top"),
        (1, [push], "push"),
        (1, [base_contact], "base_contact"),
        (1, [block_contact], "block_contact"),
    ]:
        gmsh.model.addPhysicalGroup(dim, tags, name=name)
    gmsh.model.mesh.generate(2)


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parents[1] / "tests" / "data"
    size = float(sys.argv[2]) if len(sys.argv) > 2 else 0.125
    out.mkdir(parents=True, exist_ok=True)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("block-on-base")
        build(size)
        for name, (version, binary) in FORMATS.items():
            gmsh.option.setNumber("Mesh.MshFileVersion", version)
            gmsh.option.setNumber("Mesh.Binary", binary)
            gmsh.write(str(out / f"block-on-base-{name}.msh"))
        gmsh.model.add("block-on-base-nonmatching")
        build_nonmatching(size, 8, 21)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.write(str(out / "block-on-base-nonmatching.msh"))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
