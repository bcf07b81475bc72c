"""The `wsm` Python package (crates/python) against the command line it mirrors: the same scenes,
the same numbers bit for bit, errors naming the field, batches equal to single calls, exact
derivatives equal to difference quotients, Ctrl-C stopping a run, and the client of
`wsm serve` giving the in-process result."""

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

wsm = pytest.importorskip("wsm", reason="the wsm package is not installed (pip install crates/python)")

# Keys whose values are wall-clock measurements, or counts that depend on which thread took
# which point (`factorisations`, `reused_factorisations`): they differ between any two runs of
# the CLI itself.
TIMING = ("seconds", "per_second", "time_share", "factorisations")


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if not any(t in k for t in TIMING)}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def test_examples_load_and_errors_name_the_field(tmp_path, example_scene):
    assert "tunnel-fault" in wsm.examples()
    assert wsm.example("hertz") == example_scene("hertz")
    with pytest.raises(wsm.BadInputError) as e:
        wsm.example("no-such-example")
    assert e.value.kind == "not_found" and e.value.exit_code == 2

    scene = wsm.example("block-on-base")
    scene["materials"][next(iter(scene["materials"]))]["young"] = -1.0
    with pytest.raises(wsm.BadInputError) as e:
        wsm.solve(scene)
    assert e.value.field and e.value.field.startswith("materials."), e.value.field
    assert e.value.exit_code == 2

    # The strict reader: a repeated key is refused as the CLI and the API refuse it.
    path = tmp_path / "repeated.json"
    path.write_text('{"name": "a", "name": "b"}')
    with pytest.raises(wsm.BadInputError) as e:
        wsm.load(path)
    assert "name" in str(e.value)


def test_solve_equals_the_command_line(run_wsm, tmp_path):
    cli = json.loads(run_wsm("solve", "--example", "block-on-base").stdout)
    solution = wsm.solve(wsm.example("block-on-base"))
    assert solution.summary["criteria"] == cli["criteria"]
    assert without_timings(solution.summary["mesh"]) == without_timings(cli["mesh"])
    f = solution.fields
    assert f["nodes"].shape == (cli["mesh"]["nodes"], 2)
    assert f["triangles"].shape == (cli["mesh"]["triangles"], 3)
    assert f["stress"].shape == (cli["mesh"]["triangles"], 4)
    assert len(solution.contact) > 0 and (solution.contact["pressure"] >= 0).all()
    # σ1 ≥ σ2 and von Mises from the same stresses; the profiles hold every contact pair.
    assert (f["principal_stress"][:, 0] >= f["principal_stress"][:, 1]).all()
    assert f["von_mises"].shape == (cli["mesh"]["triangles"],)
    assert len(solution.profiles) == len(solution.contact)
    assert solution.profiles.groupby("zone")["arc_length"].apply(lambda a: a.is_monotonic_increasing).all()

    # The VTU is the one `wsm solve --vtu` writes, and meshio reads it.
    cli_vtu = tmp_path / "cli.vtu"
    run_wsm("solve", "--example", "block-on-base", "--vtu", cli_vtu)
    assert solution.vtu == cli_vtu.read_text()
    mesh = solution.to_meshio()
    n = len(f["nodes"])  # the mesh's nodes first, then the contact lines' edge midpoints
    np.testing.assert_array_equal(mesh.points[:n, :2], f["nodes"])
    np.testing.assert_array_equal(mesh.cells_dict["triangle"], f["triangles"])
    np.testing.assert_array_equal(mesh.point_data["displacement"][:n, :2], f["displacement"])
    stress = mesh.cell_data_dict["stress"]["triangle"]
    assert stress.shape == (len(f["triangles"]), 6)
    np.testing.assert_array_equal(stress[:, [0, 1, 2, 3]], f["stress"][:, [0, 1, 3, 2]])


def test_worst_gives_the_command_lines_numbers_bit_for_bit(run_wsm, tmp_path):
    table = tmp_path / "cli.csv"
    cli = run_wsm("worst", "--example", "tunnel-fault", "--budget", "120", "--table", table)
    result = wsm.worst(wsm.example("tunnel-fault"), budget=120, progress=False)
    assert without_timings(json.loads(result.json)) == without_timings(json.loads(cli.stdout))
    assert len(result.extrema) == 2 * len(json.loads(cli.stdout)["criteria"])
    # The evaluations table is the CLI's, row for row, but for the solve times.
    import pandas as pd

    mine = result.evaluations.drop(columns=["solve_seconds"])
    theirs = pd.read_csv(table).drop(columns=["solve_seconds"])
    pd.testing.assert_frame_equal(mine, theirs)
    # One row per criterion and sense, its data in the parameters' columns.
    worst_phi3 = result.extrema.query("criterion == 'phi3' and sense == 'max'").iloc[0]
    entry = result.extremum("phi3", "max")
    assert worst_phi3["value"] == entry["value"]
    assert [worst_phi3[n] for n in result.parameters["name"]] == entry["point"]


def test_an_evaluator_batch_equals_single_calls_and_the_command_line(run_wsm):
    scene = wsm.example("tunnel-fault")
    ev = wsm.Evaluator(scene, criteria=["phi3", "phi6"])
    k = len(ev.names)
    assert ev.bounds.shape == (k, 2) and ev.salib_problem()["num_vars"] == k
    rng = np.random.default_rng(7)
    lo, hi = ev.bounds[:, 0], ev.bounds[:, 1]
    points = lo + rng.random((64, k)) * (hi - lo)
    batch = ev(points)
    assert batch.values.shape == (64, 2) and batch.gradient.shape == (64, 2, k)
    for i in range(64):
        values, gradient = ev(points[i])
        np.testing.assert_array_equal(values, batch.values[i])
        np.testing.assert_array_equal(gradient, batch.gradient[i])
    assert all(e is None for e in batch.errors)

    # The same point through `wsm evaluate` gives the same numbers.
    lines = json.dumps(points[0].tolist()) + "\n"
    done = run_wsm("evaluate", "--example", "tunnel-fault", "--criteria", "phi3,phi6", input=lines)
    answer = json.loads(done.stdout.splitlines()[1])
    assert [answer["values"][c] for c in ev.criteria] == batch.values[0].tolist()

    # A point outside the box is an answer with an error, not an exception.
    outside = points[:2].copy()
    outside[1, 0] = hi[0] * 2
    answers = ev(outside)
    assert answers.errors[0] is None and "outside its interval" in answers.errors[1]
    assert np.isnan(answers.values[1]).all()
    with pytest.raises(wsm.BadInputError):
        ev(np.zeros(k + 1))


def test_exact_derivatives_match_difference_quotients():
    ev = wsm.Evaluator(wsm.example("block-on-base"), criteria=["phi3", "phi6"])
    mid = ev.bounds.mean(axis=1)
    at = ev(mid)
    for j in range(len(ev.names)):
        h = 1e-5 * (ev.bounds[j, 1] - ev.bounds[j, 0])
        up, down = mid.copy(), mid.copy()
        up[j] += h
        down[j] -= h
        quotient = (ev(up).values - ev(down).values) / (2 * h)
        # The quotient's own error: the solves' rounding (~1e-11 relative) over 2h.
        rounding = 1e-11 * np.abs(at.values) / h
        assert np.all(np.abs(at.gradient_right[:, j] - quotient) <= 1e-4 * np.abs(quotient) + rounding), (
            j, at.gradient_right[:, j], quotient)
        np.testing.assert_array_equal(at.gradient_left[:, j], at.gradient_right[:, j])


def test_ctrl_c_stops_a_run_and_raises_keyboard_interrupt(tmp_path):
    script = tmp_path / "long_run.py"
    script.write_text(
        textwrap.dedent(
            """
            import sys, time, wsm
            print("started", flush=True)
            t = time.time()
            try:
                wsm.worst(wsm.example("tunnel-fault"), budget=100000, stop="budget", progress=False,
                          accuracy_refinements=0, threads=1)
            except KeyboardInterrupt:
                print(f"interrupted after {time.time() - t:.1f}", flush=True)
                sys.exit(0)
            sys.exit(3)
            """
        )
    )
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    time.sleep(3)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, out
    assert out.startswith("interrupted after")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def server(wsm_bin, tmp_path):
    port = free_port()
    proc = subprocess.Popen(
        [wsm_bin, "serve", "--addr", f"127.0.0.1:{port}", "--db", str(tmp_path / "jobs.db"), "--threads-per-job", "1"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "WSM_API_TOKEN": "secret-token"},
    )
    url = f"http://127.0.0.1:{port}"
    for _ in range(100):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            break
        except OSError:
            time.sleep(0.1)
    yield url
    proc.terminate()
    proc.wait(timeout=30)


def test_the_client_gives_the_in_process_result(server):
    local = wsm.worst(wsm.example("hertz"), budget=12, seed=3, progress=False)
    client = wsm.Client(server, token="secret-token")
    remote = client.worst(example="hertz", budget=12, seed=3, progress=False)
    for c_local, c_remote in zip(local.outcome["criteria"], remote.outcome["criteria"]):
        for sense in ("worst", "best"):
            assert c_remote[sense]["value"] == c_local[sense]["value"]
            assert c_remote[sense]["point"] == c_local[sense]["point"]
    assert list(remote.evaluations.columns) == list(local.evaluations.columns)
    assert len(remote.evaluations) == len(local.evaluations)
    job = client.submit(example="hertz", budget=4, accuracy_refinements=0)
    client.wait(job, progress=False)
    fields = client.fields(job, scenario="worst")
    assert fields.fields["nodes"].shape[1] == 2 and len(fields.contact) > 0

    with pytest.raises(wsm.WsmError) as e:
        wsm.Client(server).status(job)  # no token
    assert "401" in str(e.value)
    with pytest.raises(wsm.BadInputError) as e:
        client.submit(example="hertz", budget=0)
    assert e.value.field == "settings.budget"


@pytest.mark.parametrize("fmt", ["4.1-ascii", "4.1-binary", "2.2-ascii", "2.2-binary"])
def test_mesh_from_meshio_solves_like_the_gmsh_file(fmt):
    meshio = pytest.importorskip("meshio")
    data = Path(__file__).resolve().parents[2] / "tests" / "data"
    scene = wsm.load(data / "block-on-base-gmsh.json")
    scene["mesh"] = {"gmsh_file": str(data / f"block-on-base-{fmt}.msh")}
    from_file = wsm.solve(scene, fields=False)
    scene["mesh"] = {"inline": wsm.mesh_from_meshio(meshio.read(data / f"block-on-base-{fmt}.msh"))}
    inline = wsm.solve(scene, fields=False)
    assert inline.summary["mesh"] == from_file.summary["mesh"]
    assert from_file.summary["mesh"]["contact_pairs"] == 9
    for name, value in from_file.criteria.items():
        assert inline.criteria[name] == pytest.approx(value, rel=1e-12), name
