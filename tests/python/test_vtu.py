"""Results out (design §5.6): meshio reads every VTU and PVD series wsm writes; the arrays follow
ParaView's conventions (3-component vectors, 6-component symmetric tensors XX YY ZZ XY YZ XZ);
their values equal `wsm solve`'s JSON output; the derived measures (von Mises, principal
stresses) agree with independent formulas; the contact zones are line cells carrying each
pair's values; the field data name the scene, the scenario and its data."""

import json
import re
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

STATE_CODES = {"open": 0, "stick": 1, "slip": 2}


def text(mesh, name):
    """A text field-data array (UTF-8 bytes as UInt8)."""
    return bytes(np.asarray(mesh.field_data[name], dtype=np.uint8)).decode()


def blocks(mesh):
    kinds = [block.type for block in mesh.cells]
    assert set(kinds) <= {"triangle", "line"}, kinds
    return kinds.index("triangle"), (kinds.index("line") if "line" in kinds else None)


def solve_with_fields(run_wsm, tmp_path, scene_args, stem="solve"):
    vtu, out = tmp_path / f"{stem}.vtu", tmp_path / f"{stem}.json"
    run_wsm("solve", *scene_args, "--vtu", vtu, "--out", out)
    return meshio.read(vtu), json.loads(out.read_text()), vtu


def check_xml_conventions(path):
    """Binary arrays with a UInt64 header; vectors of 3 and the tensor of 6 components."""
    root = ET.parse(path).getroot()
    assert root.get("type") == "UnstructuredGrid"
    assert root.get("header_type") == "UInt64" and root.get("byte_order") == "LittleEndian"
    components = {}
    for array in root.iter("DataArray"):
        assert array.get("format") == "binary", array.get("Name")
        components[array.get("Name")] = int(array.get("NumberOfComponents", "1"))
    assert components["displacement"] == 3
    assert components["principal_direction_1"] == 3
    assert components["stress"] == 6
    for scalar in ("von_mises", "i2_squared", "zone_id", "body_id"):
        assert components[scalar] == 1


def check_against_json(mesh, result, scene):
    fields = result["fields"]
    nodes = np.array(fields["nodes"])
    triangles = np.array(fields["triangles"])
    tri, line = blocks(mesh)
    n = len(nodes)

    # Points: the mesh nodes first (z = 0), then the midpoints of the contact lines.
    np.testing.assert_array_equal(mesh.points[:n, :2], nodes)
    assert np.all(mesh.points[:, 2] == 0.0)
    np.testing.assert_array_equal(mesh.cells[tri].data, triangles)

    # Displacement: a 3-vector per point, the JSON's at the nodes.
    u = mesh.point_data["displacement"]
    assert u.shape == (len(mesh.points), 3)
    np.testing.assert_array_equal(u[:n, :2], np.array(fields["displacement"]))
    assert np.all(u[:, 2] == 0.0)

    # The stress tensor in ParaView's order from the JSON's (τ11, τ22, τ12, τ33).
    s = np.array(fields["stress"])
    tensor = mesh.cell_data["stress"][tri]
    assert tensor.shape == (len(triangles), 6)
    np.testing.assert_array_equal(tensor[:, 0], s[:, 0])
    np.testing.assert_array_equal(tensor[:, 1], s[:, 1])
    np.testing.assert_array_equal(tensor[:, 2], s[:, 3])
    np.testing.assert_array_equal(tensor[:, 3], s[:, 2])
    assert np.all(tensor[:, 4:] == 0.0)
    np.testing.assert_array_equal(mesh.cell_data["i2_squared"][tri], fields["i2_squared"])

    # Derived measures against independent formulas.
    s11, s22, s12, s33 = s.T
    scale = np.abs(s).max()
    von_mises = np.sqrt(0.5 * ((s11 - s22) ** 2 + (s22 - s33) ** 2 + (s33 - s11) ** 2) + 3 * s12**2)
    np.testing.assert_allclose(mesh.cell_data["von_mises"][tri], von_mises, rtol=1e-12, atol=1e-12 * scale)
    in_plane = np.stack([np.stack([s11, s12], -1), np.stack([s12, s22], -1)], -2)
    eig = np.linalg.eigvalsh(in_plane)  # ascending
    p1, p2, p3 = (mesh.cell_data[f"principal_stress_{k}"][tri] for k in (1, 2, 3))
    np.testing.assert_allclose(p1, eig[:, 1], rtol=1e-10, atol=1e-10 * scale)
    np.testing.assert_allclose(p2, eig[:, 0], rtol=1e-10, atol=1e-10 * scale)
    np.testing.assert_array_equal(p3, s33)
    d = mesh.cell_data["principal_direction_1"][tri]
    assert d.shape == (len(triangles), 3) and np.all(d[:, 2] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(
        np.einsum("eij,ej->ei", in_plane, d[:, :2]), p1[:, None] * d[:, :2], atol=1e-9 * scale
    )

    # Zone and body ids.
    zone_of_body = [b for b, body in enumerate(scene["bodies"]) for _ in body["zones"]]
    zone_id = mesh.cell_data["zone_id"][tri]
    np.testing.assert_array_equal(zone_id, fields["triangle_zone"])
    np.testing.assert_array_equal(mesh.cell_data["body_id"][tri], np.array(zone_of_body)[zone_id])
    assert text(mesh, "zone_names").split("\n") == [z["name"] for b in scene["bodies"] for z in b["zones"]]
    assert text(mesh, "body_names").split("\n") == [b["name"] for b in scene["bodies"]]

    contact = fields["contact"]
    if not contact:
        assert line is None
        return
    # Contact zones: line cells, each carrying its pair's values exactly, none on the triangles.
    lines = mesh.cells[line].data
    pair = mesh.cell_data["contact_pair"][line]
    assert sorted(set(pair)) == list(range(len(contact)))
    for name, key in [("pressure", "pressure"), ("shear", "shear"), ("gap", "gap"), ("slip", "slip")]:
        values = mesh.cell_data[f"contact_{name}"]
        np.testing.assert_array_equal(values[line], [contact[p][key] for p in pair])
        assert np.all(np.isnan(values[tri]))
    np.testing.assert_array_equal(
        mesh.cell_data["contact_state"][line], [STATE_CODES[contact[p]["state"]] for p in pair]
    )
    assert np.all(mesh.cell_data["contact_state"][tri] == -1)
    np.testing.assert_array_equal(mesh.cell_data["contact_zone_id"][line], [contact[p]["zone"] for p in pair])
    # A line runs from its pair's node to the midpoint of a contact edge.
    np.testing.assert_array_equal(mesh.points[lines[:, 0], :2], [contact[p]["position"] for p in pair])
    assert np.all(lines[:, 1] >= len(nodes))
    assert np.all(np.isnan(mesh.cell_data["stress"][line]))
    assert np.all(mesh.cell_data["zone_id"][line] == -1)
    assert text(mesh, "contact_zone_names").split("\n") == [c["name"] for c in scene["contacts"]]
    assert "1 stick" in text(mesh, "contact_state_legend")


def test_solve_vtu_matches_the_json_output(run_wsm, example_scene, tmp_path):
    mesh, result, path = solve_with_fields(run_wsm, tmp_path, ["--example", "block-on-base"])
    check_xml_conventions(path)
    scene = example_scene("block-on-base")
    check_against_json(mesh, result, scene)
    assert text(mesh, "scene") == result["summary"]["scene"] == scene["name"]
    assert text(mesh, "scenario") == "nominal"
    version = run_wsm("--version").stdout.split()[-1]
    assert text(mesh, "wsm_version") == version
    # The nominal data: the scene's own values of its uncertain data.
    data = {k[len("data:"):]: float(np.ravel(v)[0]) for k, v in mesh.field_data.items() if k.startswith("data:")}
    assert data == {
        "materials.rock.E": scene["materials"]["rock"]["E"],
        "boundary[2].traction[0]": scene["boundary"][2]["traction"][0],
        "contacts[joint].slip_limit": scene["contacts"][0]["slip_limit"],
    }


def test_temperature_of_a_heat_scene(run_wsm, example_scene, tmp_path):
    mesh, result, _ = solve_with_fields(run_wsm, tmp_path, ["--example", "heated-plate"])
    temperature = result["fields"]["temperature"]
    assert temperature is not None
    t = mesh.point_data["temperature"]
    assert t.shape == (len(mesh.points),)
    np.testing.assert_array_equal(t[: len(temperature)], temperature)
    check_against_json(mesh, result, example_scene("heated-plate"))


def set_field(scene, path, value):
    """Set the scene number at a field path such as `contacts[joint].slip_limit`."""
    target = scene
    steps = []
    for part in path.split("."):
        name, *brackets = re.findall(r"[^\[\]]+", part)
        steps.append(name)
        steps.extend(int(b) if b.isdigit() else ("entry", b) for b in brackets)
    for i, step in enumerate(steps):
        last = i == len(steps) - 1
        if isinstance(step, tuple):
            index = next(k for k, e in enumerate(target) if e.get("name") == step[1])
        else:
            index = step
        if last:
            target[index] = value
        else:
            target = target[index]


def test_worst_fields_series(run_wsm, example_scene, tmp_path):
    out, fields = tmp_path / "worst.json", tmp_path / "fields"
    run_wsm("worst", "--example", "block-on-base", "--budget", "30", "--out", out, "--fields", fields)
    outcome = json.loads(out.read_text())

    # The PVD index: nominal, then worst and best of every criterion, one time step each.
    root = ET.parse(fields / "scenarios.pvd").getroot()
    assert root.get("type") == "Collection"
    datasets = root.findall("./Collection/DataSet")
    assert [int(d.get("timestep")) for d in datasets] == list(range(len(datasets)))
    expected = [("nominal", None)] + [
        (sense, c["criterion"]) for c in outcome["criteria"] for sense in ("worst", "best")
    ]
    assert len(datasets) == len(expected) == 1 + 2 * len(outcome["criteria"])

    scene = example_scene("block-on-base")
    nominal_mesh, _, _ = solve_with_fields(run_wsm, tmp_path, ["--example", "block-on-base"], "nominal")
    for dataset, (sense, criterion) in zip(datasets, expected):
        mesh = meshio.read(fields / dataset.get("file"))
        assert text(mesh, "scene") == scene["name"]
        assert text(mesh, "scenario") == sense
        data = {k[len("data:"):]: float(np.ravel(v)[0]) for k, v in mesh.field_data.items() if k.startswith("data:")}
        if criterion is None:
            assert "criterion" not in mesh.field_data
            for name in ("displacement",):
                np.testing.assert_array_equal(mesh.point_data[name], nominal_mesh.point_data[name])
            np.testing.assert_array_equal(mesh.cell_data["stress"][0], nominal_mesh.cell_data["stress"][0])
            continue
        extremum = next(c for c in outcome["criteria"] if c["criterion"] == criterion)[sense]
        assert text(mesh, "criterion") == criterion
        assert float(np.ravel(mesh.field_data["criterion_value"])[0]) == extremum["value"]
        assert data == extremum["data"]
        # The file's fields are `wsm solve`'s on the scene with the scenario's data.
        at_data = json.loads(json.dumps(scene))
        for name, value in data.items():
            set_field(at_data, name, value)
        scene_file = tmp_path / f"{sense}-{criterion}.json"
        scene_file.write_text(json.dumps(at_data))
        _, result, _ = solve_with_fields(run_wsm, tmp_path, [scene_file], f"solve-{sense}-{criterion}")
        check_against_json(mesh, result, scene)


def test_fields_needs_a_directory_it_can_write(run_wsm, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    done = run_wsm(
        "worst", "--example", "block-on-base", "--budget", "5", "--fields", blocker / "sub", check=False
    )
    assert done.returncode == 5, done.stderr
    assert "sub" in done.stderr


def test_vtk_reads_the_tensor_as_paraview_does(run_wsm, tmp_path):
    """With VTK (PyVista) installed — it is not in the pinned requirements: ParaView's own
    reader takes the 6-component `stress` as a symmetric tensor in wsm's component order: its
    Tensor Principal Invariants filter gives the principal stresses wsm writes."""
    pv = pytest.importorskip("pyvista")
    from vtkmodules.all import vtkTensorPrincipalInvariants as Invariants

    path = tmp_path / "solve.vtu"
    run_wsm("solve", "--example", "block-on-base", "--vtu", path)
    grid = pv.read(path)
    assert set(np.unique(grid.celltypes)) == {pv.CellType.TRIANGLE, pv.CellType.LINE}
    triangles = grid.extract_cells(np.flatnonzero(grid.celltypes == pv.CellType.TRIANGLE))
    invariants = Invariants()
    invariants.SetInputData(triangles)
    invariants.Update()
    out = pv.wrap(invariants.GetOutput())
    vtk_sigma = np.sort(np.stack([out.cell_data[f"stress - Sigma {k}"] for k in (1, 2, 3)], 1), 1)
    wsm_sigma = np.sort(np.stack([triangles.cell_data[f"principal_stress_{k}"] for k in (1, 2, 3)], 1), 1)
    np.testing.assert_allclose(vtk_sigma, wsm_sigma, rtol=1e-9, atol=1e-9 * np.abs(wsm_sigma).max())
    assert bytes(grid.field_data["scenario"]).decode() == "nominal"


def test_fields_are_on_the_mesh_the_run_chose(run_wsm, tmp_path):
    """With a target error the run solves on a mesh of its ladder; its fields are on that mesh."""
    out, fields = tmp_path / "worst.json", tmp_path / "fields"
    run_wsm(
        "worst", "--example", "block-on-base", "--budget", "10", "--target-error", "0.05",
        "--accuracy-refinements", "0", "--out", out, "--fields", fields,
    )
    choice = json.loads(out.read_text())["mesh_choice"]
    chosen = next(c for c in choice["candidates"] if c["size_factor"] == choice["size_factor"])
    default = json.loads(run_wsm("solve", "--example", "block-on-base").stdout)["mesh"]["triangles"]
    assert chosen["triangles"] != default
    for path in fields.glob("*.vtu"):
        assert len(meshio.read(path).cells_dict["triangle"]) == chosen["triangles"], path.name


def test_dynamic_series_is_read_by_meshio(run_wsm, tmp_path):
    """A dynamic solve's `--vtu` (design §3.5, §5.6): one VTU per output time indexed by a PVD
    whose time steps are the history's times; meshio reads every file, with the velocity and the
    peak fields, whose largest values are the history's `peaks`."""
    vtu, out = tmp_path / "impact.vtu", tmp_path / "impact.json"
    run_wsm("solve", "--example", "implant-impact", "--vtu", vtu, "--out", out)
    history = json.loads(out.read_text())["summary"]["history"]
    steps = ET.parse(tmp_path / "impact.pvd").getroot().findall(".//DataSet")
    assert [float(s.get("timestep")) for s in steps] == history["times"]
    for k, step in enumerate(steps):
        mesh = meshio.read(tmp_path / step.get("file"))
        assert text(mesh, "scenario") == f"nominal at t = {step.get('timestep')} s"
        assert mesh.point_data["velocity"].shape[1] == 3
    triangles, lines = blocks(mesh)
    peaks = history["peaks"]
    assert np.max(mesh.point_data["peak_displacement"]) == peaks["displacement"]["value"]
    assert np.nanmax(mesh.cell_data["peak_i2_squared"][triangles]) == peaks["i2_squared"]["value"]
    assert (
        np.nanmax(mesh.cell_data["peak_contact_pressure"][lines])
        == peaks["contact_pressure"]["value"]
    )
