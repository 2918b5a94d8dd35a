"""Input that used to be misread or leave files behind: refused with one line naming the field."""
from __future__ import annotations

import math

import pytest
from mpi4py import MPI

from rollsim.geometry.cli import main as geometry_main
from rollsim.studies.bearing_capacity import Soil
from rollsim.units import FORCE, PRESSURE, InputError, to_si


@pytest.mark.parametrize("text, kind", [("1,5 kPa", PRESSURE), ("133,5 kN", FORCE), ("0,05", PRESSURE),
                                        ("133,500 N", FORCE), ("1 , 5 kPa", PRESSURE)])
def test_decimal_comma_is_refused_naming_the_field(text, kind):
    with pytest.raises(InputError, match="decimal point") as err:
        to_si(text, kind, "soil.c")
    assert err.value.field == "soil.c"


def test_decimal_point_still_reads():
    assert to_si("1.5 kPa", PRESSURE, "c") == pytest.approx(1500.0)
    assert to_si("133.5 kN", FORCE, "load") == pytest.approx(133.5e3)


@pytest.mark.parametrize("phi", [math.nan, math.inf])
def test_soil_refuses_non_finite_friction_angle(phi):
    with pytest.raises(InputError, match="phi"):
        Soil(c=10e3, phi=phi, gamma=20e3)


@pytest.mark.parametrize("flags", [["block", "--depth", "-1"], ["block", "--layers", "0.3,x"],
                                   ["example", "rolling", "--refinement", "-2"]])
def test_geometry_cli_writes_nothing_on_bad_flags(tmp_mpi_path, flags):
    out = tmp_mpi_path / "geometry"
    assert geometry_main(flags + ["--out", str(out), "--no-png", "-q"], comm=MPI.COMM_WORLD) == 2
    assert not out.exists()
