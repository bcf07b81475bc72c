"""The JSON Schema of the scene (design §5.2, "JSON Schema of the scene") against the reader.

The schema (`wsm schema`, checked in as openapi/scene.schema.json) must accept every real
scene — the bundled examples, scenes/ and the scenes under tests/data — and refuse what the
reader refuses for its shape: a misspelt key at any depth, a wrong type, a number out of its
sign rule. Where the two could disagree (the hand-written parts: criteria, the slip limit,
"$schema") each case is run through both, `wsm solve` as the reader.
"""

import copy
import json

import jsonschema
import pytest

from conftest import ROOT

DIALECT = "https://json-schema.org/draft/2020-12/schema"


@pytest.fixture(scope="session")
def schema(run_wsm):
    printed = json.loads(run_wsm("schema").stdout)
    assert printed["$schema"] == DIALECT
    jsonschema.Draft202012Validator.check_schema(printed)
    return printed


@pytest.fixture(scope="session")
def validator(schema):
    return jsonschema.Draft202012Validator(schema)


def errors(validator, scene):
    return list(validator.iter_errors(scene))


def test_the_checked_in_schema_is_the_printed_one(schema):
    checked_in = json.loads((ROOT / "openapi" / "scene.schema.json").read_text())
    assert checked_in == schema, "regenerate: wsm schema > openapi/scene.schema.json"


def real_scenes(run_wsm):
    names = run_wsm("example", "--list").stdout.split()
    assert len(names) >= 10, names
    scenes = [(f"example {n}", json.loads(run_wsm("example", n).stdout)) for n in names]
    for path in sorted((ROOT / "scenes").glob("*.json")) + [
        ROOT / "tests" / "data" / "dam-coulomb-3data.json"
    ]:
        scenes.append((str(path.relative_to(ROOT)), json.loads(path.read_text())))
    return scenes


def test_every_real_scene_is_valid(run_wsm, validator):
    scenes = real_scenes(run_wsm)
    for name, scene in scenes:
        problems = [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in errors(validator, scene)]
        assert not problems, f"{name}: {problems[:3]}"


def reader_accepts(run_wsm, tmp_path, scene):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    done = run_wsm("solve", path, check=False)
    return done.returncode == 0, done.stderr.strip()


@pytest.fixture
def block(example_scene):
    """A small scene with a contact zone (solves in a fraction of a second)."""
    return example_scene("block-on-base")


def mutated(scene, change):
    scene = copy.deepcopy(scene)
    change(scene)
    return scene


def set_in(path, value):
    def change(scene):
        node = scene
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return change


def piecewise_slip_limit(scene, slope_key):
    """The joint's slip limit piecewise linear with a slope bound under `slope_key` (the
    uncertain datum on the constant slip limit dropped)."""
    g = scene["contacts"][0]["slip_limit"]
    scene["contacts"][0]["slip_limit"] = {"knots": [0, 1], "values": [g, g], slope_key: 1e5}
    scene["uncertain"] = [u for u in scene["uncertain"] if "slip_limit" not in u["field"]]


# Each case: a change of the block scene, and whether the reader and the schema accept it.
CASES = {
    # Misspelt keys at several depths.
    "misspelt root key": (set_in(["meshh"], {"max_size": 0.1}), False),
    "misspelt material key": (lambda s: s["materials"][next(iter(s["materials"]))].update(Young=1e9), False),
    "misspelt mesh key": (set_in(["mesh", "max_sise"], 0.1), False),
    "misspelt search key": (set_in(["search", "budgett"], 10), False),
    "misspelt contact key": (lambda s: s["contacts"][0].update(frictoin_coefficient=0.3), False),
    "misspelt slip-limit member": (lambda s: piecewise_slip_limit(s, "max_slop"), False),
    # Wrong types.
    "mesh size as text": (set_in(["mesh", "max_size"], "0.1"), False),
    "bodies as an object": (lambda s: s.update(bodies={"b": s["bodies"][0]}), False),
    "material as an array": (lambda s: s["materials"].update({next(iter(s["materials"])): [1e9, 0.3]}), False),
    # Out of a sign or range rule.
    "negative mesh size": (set_in(["mesh", "max_size"], -0.1), False),
    "Poisson's ratio 0.5": (lambda s: s["materials"][next(iter(s["materials"]))].update(nu=0.5), False),
    "negative slip limit": (lambda s: s["contacts"][0].update(slip_limit=-1.0), False),
    "version 2": (set_in(["version"], 2), False),
    # Accepted forms.
    "a $schema key": (set_in(["$schema"], "../openapi/scene.schema.json"), True),
    "criteria in every form": (
        set_in(["search", "criteria"], ["phi3", " PHI5 ", {"criterion": "phi3"}]),
        True,
    ),
    "a piecewise slip limit": (lambda s: piecewise_slip_limit(s, "max_slope"), True),
    "a defined criterion searched by its name": (lambda s: defined(s, "mean_von_mises", "von_mises"), True),
    # Defined criteria the reader refuses by shape.
    "a defined criterion named like a phi": (lambda s: defined(s, "phi7", "von_mises"), False),
    "a defined criterion of an unknown quantity": (lambda s: defined(s, "vm", "tresca"), False),
    # Criteria the reader refuses by shape.
    "unknown criterion": (set_in(["search", "criteria"], ["phi7"]), False),
    "blank region": (set_in(["search", "criteria"], ["phi3@ "]), False),
    "criterion object with a misspelt key": (
        set_in(["search", "criteria"], [{"criterion": "phi3", "regoin": "x"}]),
        False,
    ),
}


def defined(scene, name, quantity):
    """Define a criterion over the scene's first area and search for it by name."""
    region = scene["criteria"]["regions"][0]["name"]
    scene["criteria"]["defined"] = [{"name": name, "region": region, "quantity": quantity}]
    scene["search"]["criteria"] = [name]


@pytest.mark.parametrize("case", sorted(CASES))
def test_schema_and_reader_agree(case, block, validator, run_wsm, tmp_path):
    change, accepted = CASES[case]
    scene = mutated(block, change)
    reader, message = reader_accepts(run_wsm, tmp_path, scene)
    by_schema = not errors(validator, scene)
    assert reader == accepted, f"reader: {message}"
    assert by_schema == accepted, [e.message for e in errors(validator, scene)]


def test_the_unchanged_block_is_accepted_by_both(block, validator, run_wsm, tmp_path):
    assert reader_accepts(run_wsm, tmp_path, block)[0]
    assert not errors(validator, block)


def test_descriptions_carry_units(schema):
    material = schema["$defs"]["Material"]["properties"]
    assert "[Pa]" in material["E"]["description"]
    assert "[N/m³]" in material["specific_weight"]["description"]
    assert "[m]" in schema["$defs"]["MeshControls"]["properties"]["max_size"]["description"]
    assert "\\[" not in json.dumps(schema), "rustdoc escapes left in a description"
