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


@pytest.mark.timeout(120)
def test_gmsh_build_failure_on_rank0_fails_every_rank(comm, monkeypatch):
    """A failure while rank 0 builds the gmsh model reaches every rank (none waits in the
    distribution that follows), with the same type and message."""
    import rollsim.geometry.soil as soil

    def broken_grid(model, axes):
        raise ValueError("injected failure while meshing")

    monkeypatch.setattr(soil, "_build_grid", broken_grid)
    block = soil.indentation_block(1.0)
    with pytest.raises(ValueError, match="injected failure while meshing"):
        soil.build_soil_block(comm, block, soil.MeshOptions.from_accuracy(1.0, "fast"))


def test_root_block_passes_on_an_unpicklable_exception(comm):
    from rollsim.mpi import RootError, root_block

    class LocalError(Exception):  # a local class cannot be pickled
        pass

    expected = LocalError if comm.rank == 0 else RootError
    with pytest.raises(expected, match="local failure"):
        with root_block(comm) as on_root:
            if on_root:
                raise LocalError("local failure")
