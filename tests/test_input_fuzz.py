"""Property-based checks of the input layer: random scene documents and command lines never end
in a traceback; the outcome is a scene, or an InputError / exit status 0, 2 or 3."""
from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rollsim.cli import main
from rollsim.scene import parse_scene
from rollsim.units import InputError

pytestmark = pytest.mark.serial

SCENE_KEYS = {
    "wheel": ["type", "shape", "diameter", "width", "fillet", "friction", "hub_diameter", "inflation",
              "E_carcass", "nu_carcass", "t_tread", "colour"],
    "soil": ["gamma", "layers", "water"],
    "layer": ["model", "E", "nu", "thickness", "phi_dp", "c_dp", "c", "phi", "match", "dilation", "psi"],
    "loading": ["protocol", "max_sinkage", "load", "travel", "speed"],
    "model": ["accuracy", "kinematics", "linear_solver", "volumetric_strain", "relaxation_length",
              "regularising_cohesion", "cell_type", "elements_across_wheel", "elements_along_path", "mesh"],
}
WORDS = ["rigid", "pneumatic", "torus", "cylinder", "von-mises", "drucker-prager", "mohr-coulomb", "indentation",
         "rolling-continuous", "rolling-constant-load", "fast", "standard", "compression", "plane-strain",
         "cell-average", "pointwise", "hexahedra", "tetrahedra", "1.5 m", "0.4 m", "40 MPa", "100 kPa", "30 deg", "133.5 kN", "1,5 kPa",
         "2 m/s", "-1 m", "1e400 Pa", "nan", "inf", "", "\u00e9", "{x}"]
values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
              st.sampled_from(WORDS), st.text(max_size=8)),
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=3)),
    max_leaves=6)


def _table(keys):
    return st.dictionaries(st.sampled_from(keys), values, max_size=len(keys))


layers = st.lists(_table(SCENE_KEYS["layer"]), max_size=3)
scenes = st.fixed_dictionaries({}, optional={
    "wheel": st.one_of(_table(SCENE_KEYS["wheel"]), values),
    "soil": st.one_of(st.fixed_dictionaries({"layers": layers}, optional={"gamma": values}), values),
    "loading": st.one_of(_table(SCENE_KEYS["loading"]), values),
    "model": st.one_of(_table(SCENE_KEYS["model"]), values),
    "extra": values})


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes)
def test_random_scenes_are_accepted_or_refused_naming_a_field(doc):
    try:
        parse_scene(doc)
    except InputError as e:
        assert e.field and e.message


FLAGS = ["--c", "--phi", "--gamma", "--load", "--sinkage", "--d", "--b", "--flex", "--c2", "--phi2", "--d2", "--b2",
         "--load2", "--sinkage2", "--mode", "--method", "--shape", "--depth", "--json", "--quiet"]
ARGS = ["100 kPa", "30", "0", "-5", "20 kN/m^3", "133.5 kN", "0.05", "1.5 m", "0.4", "1e-6 m/N", "rolling",
        "indentation", "footing", "load", "torus", "theory", "1,5", "abc", "nan", "1e308", "90", "89.9"]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["predict", "invert", "influence"]),
       st.lists(st.tuples(st.sampled_from(FLAGS), st.sampled_from(ARGS)), max_size=6))
def test_random_command_lines_end_in_0_2_or_3(command, pairs):
    argv = [command] + [x for pair in pairs for x in pair]
    assert main(argv) in (0, 2, 3), argv
