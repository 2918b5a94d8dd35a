"""Scene files: the examples load, SI conversion, and every bad value is one line naming its key."""
import json
import math
import pathlib
import tomllib

import pytest

from rollsim.cli import main
from rollsim.scene import DEFAULT_E_CARCASS, load_scene, parse_scene
from rollsim.units import InputError

EXAMPLES = pathlib.Path(__file__).parents[1] / "examples"

BASE = {
    "wheel": {"diameter": "60 in", "width": "18 in"},
    "soil": {"gamma": "127 pcf", "layers": [{"model": "drucker-prager", "E": "40 MPa", "nu": 0.35,
                                              "phi_dp": "27.5 deg", "c_dp": "194.6 kPa"}]},
    "loading": {"protocol": "indentation", "max_sinkage": "6 in"},
}


def with_change(path: str, value):
    """BASE with the dotted ``path`` set to ``value`` (None deletes)."""
    data = json.loads(json.dumps(BASE))
    *parents, last = path.replace("]", "").replace("[", ".").split(".")
    node = data
    for p in parents:
        node = node[int(p)] if p.isdigit() else node.setdefault(p, {})
    if value is None:
        del node[last]
    else:
        node[last] = value
    return data


def test_examples_load():
    scenes = {p.name: load_scene(p) for p in sorted(EXAMPLES.glob("*.toml"))}
    assert len(scenes) >= 2
    rolling = scenes["rolling_layered.toml"]
    assert rolling.wheel.diameter == pytest.approx(1.524) and rolling.wheel.fillet == pytest.approx(0.4572 / 12)
    assert rolling.soil.layers[0].thickness == pytest.approx(0.61) and rolling.soil.layers[-1].thickness is None
    assert rolling.loading.load == 133.5e3 and rolling.model.accuracy == "fast"
    assert rolling.model.volumetric_strain == "pointwise"           # rolling on the fast preset
    assert rolling.model.relaxation_length == pytest.approx(1e-3)    # the non-associated sand needs it
    towed = scenes["pneumatic_rolling.toml"]
    assert towed.wheel.type == "pneumatic" and towed.loading.protocol == "rolling-constant-load"
    assert towed.model.accuracy == "fast" and towed.model.volumetric_strain == "cell-average"   # hexahedra: Q2-P1
    assert towed.wheel.E_carcass == 50e6                            # given: softer than the default
    tire = tomllib.loads((EXAMPLES / "pneumatic_rolling.toml").read_text())
    del tire["wheel"]["E_carcass"]
    assert parse_scene(tire).wheel.E_carcass == DEFAULT_E_CARCASS == 78e6   # the calibrated modulus, docs/tire.md


def test_si_conversion_and_defaults():
    scene = parse_scene(BASE)
    layer = scene.soil.layers[0]
    assert scene.soil.gamma == pytest.approx(127 * 4.4482216152605 / 0.3048**3)
    assert layer.phi_dp == pytest.approx(math.radians(27.5)) and layer.c_dp == 194.6e3 and layer.dilation == 0
    assert scene.wheel.friction == 0.8 and scene.wheel.type == "rigid" and scene.model.accuracy == "standard"
    assert scene.model.kinematics == "small-strain"
    assert parse_scene(with_change("model.kinematics", "updated-lagrangian")).model.kinematics == "updated-lagrangian"
    assert scene.model.linear_solver == "auto"
    assert parse_scene(with_change("model.linear_solver", "iterative")).model.linear_solver == "iterative"
    assert scene.model.volumetric_strain == "cell-average"          # indentation: B-bar by default
    assert parse_scene(with_change("model.volumetric_strain", "pointwise")).model.volumetric_strain == "pointwise"
    assert scene.loading.max_sinkage == pytest.approx(0.1524)
    assert scene.model.relaxation_length == 0                      # rate-independent unless asked for
    rolling = with_change("loading", {"protocol": "rolling-continuous", "max_sinkage": "1 in", "travel": "3 m"})
    rolling["model"] = {"relaxation_length": "1 mm"}
    assert parse_scene(rolling).model.relaxation_length == pytest.approx(1e-3)
    assert parse_scene(rolling).model.volumetric_strain == "cell-average"     # rolling, standard: B-bar
    rolling["model"]["accuracy"] = "fast"
    assert parse_scene(rolling).model.volumetric_strain == "pointwise"        # rolling, fast: pointwise
    rolling["model"]["refinement"] = 12                                        # elements per d, over the preset
    finer = parse_scene(rolling).model
    assert finer.elements_per_d == 12 and finer.volumetric_strain == "cell-average" and finer.accuracy == "fast"
    assert finer.mesh_name == "12 elements per d" and scene.model.elements_per_d == 20    # standard preset
    assert parse_scene(with_change("model.relaxation_length", "0.01 mm")).model.relaxation_length == pytest.approx(1e-5)
    assert scene.model.regularising_cohesion == 1e3                 # in place of c = 0; 0 keeps c = 0
    assert parse_scene(with_change("model.regularising_cohesion", 0)).model.regularising_cohesion == 0
    assert scene.model.plateau_tolerance == 1e-4                    # Newton plateaus; 0: never accepted
    assert parse_scene(with_change("model.plateau_tolerance", 0)).model.plateau_tolerance == 0
    assert scene.to_dict()["soil"]["layers"][0]["phi_dp"] == pytest.approx(27.5)


@pytest.mark.parametrize("path, value, field", [
    ("wheel.diameter", "-1 m", "wheel.diameter"),
    ("wheel.diameter", None, "wheel.diameter"),
    ("wheel.width", "12 kg", "wheel.width"),
    ("wheel.fillet", "0.3 m", "wheel.fillet"),
    ("wheel.shape", "square", "wheel.shape"),
    ("wheel.friction", -0.1, "wheel.friction"),
    ("wheel.colour", "red", "wheel.colour"),
    ("soil.gamma", "abc", "soil.gamma"),
    ("soil.layers", [], "soil.layers"),
    ("soil.layers[0].nu", 0.5, "soil.layers[0].nu"),
    ("soil.layers[0].E", "0 MPa", "soil.layers[0].E"),
    ("soil.layers[0].model", "cam-clay", "soil.layers[0].model"),
    ("soil.layers[0].c", "10 kPa", "soil.layers[0].c"),
    ("soil.layers[0].dilation", "30 deg", "soil.layers[0].dilation"),
    ("soil.layers[0].thickness", "1 m", "soil.layers[0].thickness"),
    ("loading.protocol", "bouncing", "loading.protocol"),
    ("loading.max_sinkage", "1 m", "loading.max_sinkage"),
    ("model.accuracy", "perfect", "model.accuracy"),
    ("model.kinematics", "total-lagrangian", "model.kinematics"),
    ("model.linear_solver", "cholesky", "model.linear_solver"),
    ("model.volumetric_strain", "mean", "model.volumetric_strain"),
    ("model.relaxation_length", "-1 mm", "model.relaxation_length"),
    ("model.relaxation_length", "1 kg", "model.relaxation_length"),
    ("model.regularising_cohesion", "-1 kPa", "model.regularising_cohesion"),
    ("model.plateau_tolerance", -1e-3, "model.plateau_tolerance"),
    ("model.plateau_tolerance", 0.5, "model.plateau_tolerance"),
    ("model.refinement", 1, "model.refinement"),
    ("model.refinement", "12 mm", "model.refinement"),
    ("model.cell_type", "hexahedra", "model.cell_type"),                # indentation: tetrahedral
    ("model.elements_across_wheel", 8, "model.elements_across_wheel"),  # rolling only
    ("model.elements_along_path", 12, "model.elements_along_path"),      # rolling only
])
def test_bad_scene_one_line_exit_2(tmp_path, capsys, path, value, field):
    scene = tmp_path / "scene.toml"
    scene.write_text(_to_toml(with_change(path, value)))
    code = main(["check", str(scene)])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rollsim: error: {field}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]  # nothing written


def test_hexahedral_rolling_block_options():
    """[model] cell_type / elements_across_wheel / elements_along_path: rolling a rigid wheel only;
    by default hexahedra with B-bar on standard (6 per d, 8 across, 12 per d along the path) and
    accurate (8, 16, 24), tetrahedra on fast and with a refinement; refused on tetrahedra, out of
    range and (along the path) coarser than the elements per d, named in the mesh's name."""
    rolling = with_change("loading", {"protocol": "rolling-constant-load", "load": "133.5 kN", "travel": "3 m"})
    expected = {"standard": ("hexahedra", 6, 8, 12, "cell-average"),
                "accurate": ("hexahedra", 8, 16, 24, "cell-average"),
                "fast": ("tetrahedra", 8, None, None, "pointwise")}
    for accuracy, cells in expected.items():
        rolling["model"] = {"accuracy": accuracy}
        model = parse_scene(rolling).model
        assert (model.cell_type, model.elements_per_d, model.elements_across_wheel, model.elements_along_path,
                model.volumetric_strain) == cells
    assert model.mesh_name == "fast"
    rolling["model"] = {}
    assert (parse_scene(rolling).model.mesh_name
            == "standard (hexahedra, 6 per d, 8 across the wheel, 12 per d along the path)")
    rolling["model"] = {"refinement": 12}                   # elements per d over the preset: tetrahedra
    model = parse_scene(rolling).model
    assert (model.cell_type, model.elements_per_d, model.elements_across_wheel) == ("tetrahedra", 12, None)
    rolling["model"] = {"cell_type": "hexahedra", "refinement": 10}
    model = parse_scene(rolling).model
    assert (model.elements_across_wheel, model.elements_along_path) == (8, 10)
    rolling["model"]["elements_along_path"] = 20
    assert parse_scene(rolling).model.elements_along_path == 20
    rolling["model"]["elements_along_path"] = 8                # coarser along the path than per d
    with pytest.raises(InputError, match="at least the elements per d") as err:
        parse_scene(rolling)
    assert err.value.field == "model.elements_along_path"
    rolling["model"] = {"cell_type": "hexahedra", "accuracy": "fast"}
    model = parse_scene(rolling).model
    assert model.elements_across_wheel == 8 and model.mesh_name == "fast (hexahedra, 6 per d, 8 across the wheel)"
    assert model.volumetric_strain == "pointwise"
    rolling["model"]["elements_across_wheel"] = 12
    assert parse_scene(rolling).model.elements_across_wheel == 12
    for value in (0, 500):
        rolling["model"]["elements_across_wheel"] = value
        with pytest.raises(InputError) as err:
            parse_scene(rolling)
        assert err.value.field == "model.elements_across_wheel"
    for key in ("elements_across_wheel", "elements_along_path"):
        rolling["model"] = {"cell_type": "tetrahedra", key: 8}
        with pytest.raises(InputError, match="needs cell_type") as err:
            parse_scene(rolling)
        assert err.value.field == f"model.{key}"
    tire = {"type": "pneumatic", "diameter": "1.2 m", "width": "0.4 m", "hub_diameter": "0.6 m",
            "inflation": "600 kPa", "E_carcass": "200 MPa"}
    rolling.update(wheel=tire, model={"cell_type": "hexahedra"})
    with pytest.raises(InputError, match="applies to rolling a rigid wheel") as err:
        parse_scene(rolling)
    assert err.value.field == "model.cell_type"


def test_steady_rolling_rules():
    """[model] rolling = "steady": a rigid cylinder on uniform or layered soil, small strain;
    travel not needed; its elements per d are the steady presets'; the transient block's keys are
    refused as not applying, and so is the key on indentation, a tire and a torus."""
    steady = with_change("loading", {"protocol": "rolling-constant-load", "load": "133.5 kN"})
    steady["model"] = {"rolling": "steady", "accuracy": "fast"}
    scene = parse_scene(steady)
    assert scene.model.rolling == "steady" and scene.loading.travel is None
    assert scene.model.elements_per_d == 20 and scene.model.cell_type is None
    assert scene.model.mesh_name == "fast (steady window, 20 elements per d at the contact)"
    steady["model"]["refinement"] = 12
    assert parse_scene(steady).model.elements_per_d == 12
    layered = json.loads(json.dumps(steady))
    layered["soil"]["layers"] = [{**BASE["soil"]["layers"][0], "thickness": "0.5 m"}, BASE["soil"]["layers"][0]]
    assert len(parse_scene(layered).soil.layers) == 2
    assert parse_scene(steady).loading.passes is None
    relaxed = json.loads(json.dumps(steady))
    relaxed["model"]["relaxation_length"] = "2 mm"
    assert parse_scene(relaxed).model.relaxation_length == pytest.approx(2e-3)
    steady["loading"]["passes"] = 3
    assert parse_scene(steady).loading.passes == 3
    for bad in (0, 2.5, True, "3", 51):
        steady["loading"]["passes"] = bad
        with pytest.raises(InputError) as err:
            parse_scene(steady)
        assert err.value.field == "loading.passes", bad
    del steady["loading"]["passes"]
    transient = json.loads(json.dumps(steady))
    transient["loading"].update(passes=2, travel="3 m")
    transient["model"]["rolling"] = "transient"
    with pytest.raises(InputError) as err:                   # more passes need the steady solver
        parse_scene(transient)
    assert err.value.field == "loading.passes"
    transient = with_change("loading", {"protocol": "rolling-constant-load", "load": "133.5 kN"})
    with pytest.raises(InputError) as err:                   # transient rolling needs its travel
        parse_scene(transient)
    assert err.value.field == "loading.travel"
    tire = {"type": "pneumatic", "diameter": "1.2 m", "width": "0.4 m", "hub_diameter": "0.6 m",
            "inflation": "600 kPa", "E_carcass": "200 MPa"}
    refused = [("model.rolling", {"loading": BASE["loading"]}),
               ("model.rolling", {"wheel": tire}),
               ("model.rolling", {"wheel": {**BASE["wheel"], "shape": "torus"}}),
               ("model.kinematics", {"model": {"rolling": "steady", "kinematics": "updated-lagrangian"}}),
               ("model.cell_type", {"model": {"rolling": "steady", "cell_type": "hexahedra"}}),
               ("model.travel_relaxation_fallback",
                {"model": {"rolling": "steady", "travel_relaxation_fallback": "1 mm"}})]
    for field, change in refused:
        data = json.loads(json.dumps(steady))
        data.update(change)
        data.setdefault("model", {})["rolling"] = "steady"
        with pytest.raises(InputError) as err:
            parse_scene(data)
        assert err.value.field == field, (field, change)


def test_summary_scene_echo_parses_back():
    """The scene echoed in summary.json (``Scene.to_dict``) reads back as the same scene (the
    report rebuilds it), for every example, a hexahedral and a steady rolling scene."""
    from rollsim.studies.report import _scene_input
    hexahedral = with_change("loading", {"protocol": "rolling-constant-load", "load": "133.5 kN", "travel": "3 m"})
    hexahedral["model"] = {"cell_type": "hexahedra", "elements_across_wheel": 12}
    steady = with_change("loading", {"protocol": "rolling-continuous", "max_sinkage": "10 mm"})
    steady["model"] = {"rolling": "steady"}
    for scene in [load_scene(p) for p in sorted(EXAMPLES.glob("*.toml"))] + [parse_scene(hexahedral),
                                                                             parse_scene(steady)]:
        assert parse_scene(_scene_input(scene.to_dict())) == scene


def test_two_layer_rules():
    data = with_change("soil.layers", BASE["soil"]["layers"] * 2)
    with pytest.raises(InputError) as e:  # the first layer needs a thickness, the last must not have one
        parse_scene(data)
    assert e.value.field == "soil.layers[0].thickness"


def test_not_toml(tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text("[wheel\n")
    assert main(["check", str(scene)]) == 2
    assert "not valid TOML" in capsys.readouterr().err


def _to_toml(data: dict) -> str:
    """Just enough TOML writing for these tests (tables, arrays of tables, scalars)."""
    def scalar(v):
        return json.dumps(v) if not isinstance(v, bool) else str(v).lower()
    lines = []
    for section, table in data.items():
        lines.append(f"[{section}]")
        for k, v in table.items():
            if isinstance(v, list) and v and isinstance(v[0], dict):
                continue
            lines.append(f"{k} = {scalar(v) if not isinstance(v, list) else '[]'}")
        for k, v in table.items():
            if isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    lines.append(f"[[{section}.{k}]]")
                    lines.extend(f"{ik} = {scalar(iv)}" for ik, iv in item.items())
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("path, value", [("soil.layers[0].E", "1e40 Pa"), ("wheel.diameter", "1e30 m"),
                                         ("wheel.friction", 50), ("soil.gamma", "2000 kN/m^3"),
                                         ("loading.max_sinkage", "1e-9 m")])
def test_implausible_values_are_refused_naming_the_key(path, value):
    with pytest.raises(InputError, match="outside the plausible range") as err:
        parse_scene(with_change(path, value))
    assert err.value.field == path


def test_atypical_value_is_accepted_with_a_warning():
    import logging
    records = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append            # the rollsim logger may not propagate (CLI set-up)
    logger = logging.getLogger("rollsim.scene")
    logger.addHandler(handler)
    try:
        scene = parse_scene(with_change("soil.layers[0].E", "500 kPa"))
    finally:
        logger.removeHandler(handler)
    assert scene.soil.layers[0].E == 500e3
    assert any("soil.layers[0].E = 500000 Pa is outside the typical range" in r.getMessage() for r in records)


def test_plausibility_table_in_the_docs_matches():
    from rollsim.scene import PLAUSIBLE
    page = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "scene.md").read_text()
    for key, (lo, hi, tlo, thi) in PLAUSIBLE.items():
        assert f"| `{key}` | {lo:g} to {hi:g} | {tlo:g} to {thi:g} |" in page, key


@pytest.mark.parametrize("path, value, context", [
    ("loading.load", "100 kN", "protocol indentation"),
    ("wheel.inflation", "650 kPa", "a rigid wheel"),
    ("soil.layers[0].match", "compression", "a drucker-prager layer given by phi_dp/c_dp"),
])
def test_known_key_that_does_not_apply_is_named_as_such(path, value, context):
    with pytest.raises(InputError, match=f"does not apply to {context}") as err:
        parse_scene(with_change(path, value))
    assert err.value.field == path
    with pytest.raises(InputError, match="unknown key"):
        parse_scene(with_change(path.rsplit(".", 1)[0] + ".colour", "red"))


def test_a_preset_is_one_record_that_the_scene_resolves():
    """What a preset sets lives in rollsim.presets alone: the geometry's element sizes and the
    solver's choices are read from it, and a scene's ``model.preset`` is the record resolved with
    its refinement (which replaces every element size and rolls on tetrahedra)."""
    from rollsim.geometry.mesh import ACCURACY_REFINEMENT
    from rollsim.presets import PRESETS, resolve_preset
    from rollsim.solver.options import ACCURACIES, DEFAULT_ACCURACY
    assert ACCURACY_REFINEMENT == {name: p.elements_per_d for name, p in PRESETS.items()}
    assert ACCURACIES == tuple(PRESETS) and DEFAULT_ACCURACY in PRESETS
    refined = resolve_preset("standard", 11.0)
    assert (refined.elements_per_d, refined.steady_elements_per_d, refined.hexahedra[0], refined.hexahedra[2]) \
        == (11.0, 11.0, 11.0, 11.0)
    assert refined.rolling_cell_type == "tetrahedra" and refined.rolling_volumetric_strain == "cell-average"
    assert resolve_preset("standard", 8.0).rolling_volumetric_strain == "pointwise"
    with pytest.raises(ValueError, match="accuracy must be one of"):
        resolve_preset("coarse")
    data = {"wheel": {"diameter": "1 m", "width": "0.3 m"},
            "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "von-mises", "E": "40 MPa", "nu": 0.3, "c": "100 kPa"}]},
            "loading": {"protocol": "rolling-constant-load", "load": "50 kN", "travel": "1 m"},
            "model": {"accuracy": "accurate"}}
    model = parse_scene(data).model
    assert model.preset is PRESETS["accurate"] and model.elements_per_d == PRESETS["accurate"].hexahedra[0]
    data["model"]["rolling"] = "steady"
    assert parse_scene(data).model.elements_per_d == PRESETS["accurate"].steady_elements_per_d
