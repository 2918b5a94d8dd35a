"""Pneumatic tire on soil (solver/pneumatic.py): the inflated carcass and the soil in one Newton
system, coupled by two-body contact.

Mn/DOT-size tire (d = 1.524 m, quarter model, carcass E = 50 MPa, nu = 0.45, elements of 0.15 m)
inflated to 450 kPa over a quarter soil block 1.5 m x 1.5 m x 1.5 m of hexahedra.  On a soil
ten times stiffer than the carcass the tire carries what the verified carcass carries on rigid
ground; on a clay it sinks, and the soil's bottom carries the wheel load.
"""
from __future__ import annotations

import csv
import json
import pathlib
import re

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from rollsim.cli import main

from rollsim.geometry import (MeshOptions, build_tire, build_tire_on_soil, indentation_block, pneumatic_tire,
                              rolling_block)
from rollsim.solver import NeoHookean, StepControl, VonMises
from rollsim.solver.carcass import Carcass
from rollsim.solver.pneumatic import TIRE_PENALTY, PneumaticIndentation
from rollsim.solver.pneumatic_rolling import PneumaticRolling

D, PRESSURE, SIZE = 1.524, 450e3, 0.15
CARCASS = NeoHookean(50e6, 0.45)


def _tire(gap: float = 0.03):
    return pneumatic_tire(D, cut="quarter", gap=gap)


def _block():
    return indentation_block(D, half_size=1.0, depth=1.0, cut="quarter")


def _tire_on_soil(comm, soil, friction: float, penalty: float, gap: float = 0.03) -> PneumaticIndentation:
    tm = build_tire_on_soil(comm, _tire(gap), _block(), MeshOptions.from_refinement(D, 6, order=2, hexahedra=True),
                            MeshOptions(SIZE, SIZE, 1.0, order=2))
    return PneumaticIndentation(tm, _tire(gap), soil, CARCASS, friction=friction, penalty=penalty)


def _bottom_reaction(pn) -> float:
    """Vertical reaction of the soil's bottom, whole wheel (N)."""
    w = fem.Function(pn.problem.V)
    depth = _block().depth
    w.sub(2).interpolate(lambda x: np.where(np.isclose(x[2], -depth), 1.0, 0.0))
    return pn.factor * pn.problem.internal_force(w)


def test_tire_on_soil_names_what_is_wrong(comm):
    with pytest.raises(ValueError, match="hexahedra"):
        build_tire_on_soil(comm, _tire(), _block(), MeshOptions.from_refinement(D, 6), MeshOptions(SIZE, SIZE, 1.0))
    with pytest.raises(ValueError, match="cut"):
        build_tire_on_soil(comm, pneumatic_tire(D, cut="half"), _block(),
                           MeshOptions.from_refinement(D, 6, hexahedra=True), MeshOptions(SIZE, SIZE, 1.0))


@pytest.mark.end_to_end
def test_a_tire_that_inflates_into_the_soil_is_refused(comm):
    """The tread grows by 22 mm at 450 kPa; placed 8 mm above the soil, it would inflate in contact."""
    pn = _tire_on_soil(comm, VonMises(E=20e6, nu=0.3, yield_stress=1e5), friction=0.0, penalty=3.0, gap=0.005)
    with pytest.raises(ValueError, match="reaches the soil"):
        pn.inflate(PRESSURE)


@pytest.mark.verification
def test_tire_on_stiff_soil_carries_what_it_carries_on_rigid_ground(comm):
    """Frictionless, on an elastic soil ten times stiffer than the carcass, pressed 30 mm after
    touching: the wheel load is that of the carcass on rigid ground (its own verified model, the
    same tire mesh) within 1 % (the soil settles by 0.2 mm; measured -0.3 %, pressed in two steps,
    of 7 and 4 Newton iterations); the soil's bottom carries it to 1e-8."""
    deflection = 0.03
    ground = Carcass(build_tire(comm, _tire(), MeshOptions(SIZE, SIZE, 1.0, order=2)), CARCASS, ground=0.0)
    ground.inflate(PRESSURE)
    ground.press(ground.lowest_point(), StepControl(dt=1.0, dt_max=1.0))     # a rigid move, clear of the ground
    ground.press(deflection, StepControl(dt=0.25, dt_min=1e-4, dt_max=0.5, easy_iterations=6))
    rigid = 4 * ground.ground_force()
    pn = _tire_on_soil(comm, VonMises(E=10 * CARCASS.E, nu=0.3, yield_stress=1e12), friction=0.0, penalty=10.0)
    pn.inflate(PRESSURE)
    pn.touch()
    records = pn.press(deflection, StepControl(dt=0.5, dt_max=0.5))
    Q = pn.wheel_load()
    assert abs(Q / rigid - 1) < 0.01, (Q, rigid)
    assert abs(_bottom_reaction(pn) / Q - 1) < 1e-8
    assert max(r.iterations for r in records) <= 8, [r.iterations for r in records]


@pytest.mark.verification
def test_tire_sinks_into_clay(comm):
    """On a clay (von Mises, c = 60 kPa, E = 20 MPa), mu = 0.5: the hub lowered by 60 mm after
    touching presses the tire in; the soil yields under it; the sinkage (the lowest tire point) is
    a part of the hub's travel, the rest the tire's deflection; Newton needs few iterations per
    step; the soil's bottom carries the wheel load.  The tread's contact arc is flatter than the
    tire (equivalent diameter above d: a positive flexibility) and the gas carries most of the
    load (measured in steps of 15 mm: sinkage 21 mm, at most 6 Newton iterations a step, d_e = 1.74 d,
    carcass share 13 %)."""
    pn = _tire_on_soil(comm, VonMises(E=20e6, nu=0.3, yield_stress=3 ** 0.5 * 60e3), friction=0.5, penalty=3.0)
    pn.inflate(PRESSURE)
    pn.touch()
    travel = 0.06
    records = pn.press(travel, StepControl(dt=0.25, dt_max=0.25))
    sinkage, Q = -pn.lowest_point(), pn.wheel_load()
    assert 0.1 * travel < sinkage < 0.9 * travel, sinkage
    assert pn.problem.counts()["plastic"] > 0
    assert max(r.iterations for r in records) <= 8, [r.iterations for r in records]
    assert Q > 0 and abs(_bottom_reaction(pn) / Q - 1) < 1e-6, Q
    tire = pn.tire_state()
    assert tire["hub_displacement_m"] == pytest.approx(travel)
    assert tire["deflection_m"] == pytest.approx(travel - sinkage)
    assert tire["equivalent_diameter_m"] > 1.2 * D and tire["flexibility_m_per_N"] > 0, tire
    assert 0 < tire["carcass_load_share"] < 0.5, tire


# ------------------------------------------------------------------------- rollsim run
EXAMPLE = pathlib.Path(__file__).parents[1] / "examples" / "pneumatic_indentation.toml"


def _scene_file(path: pathlib.Path, text: str) -> pathlib.Path:
    """``text`` written to ``path`` by rank 0, there for every rank."""
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    return path


#: elements per d of the solved example scenes: coarser than the fast preset's 8, so fewer dofs
#: and contact points (the tire is meshed at the soil's fine size, d / 6)
SCENE_REFINEMENT = 6


def _example(tmp, **changes) -> pathlib.Path:
    """The example scene with ``key = value`` lines replaced (TOML text), meshed with
    ``SCENE_REFINEMENT`` elements per d."""
    text = EXAMPLE.read_text()
    for key, value in changes.items():
        text = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
    text += f"refinement = {SCENE_REFINEMENT}\n"                  # [model] is the last table
    return _scene_file(tmp / f"scene_{'_'.join(changes) or 'example'}.toml", text)


@pytest.mark.end_to_end
def test_pneumatic_scene_runs_end_to_end(comm, tmp_mpi_path):
    """``rollsim run`` of the example (6 elements per d) pressed to 12 mm: exit 0, a history, and the
    tire's figures in summary.json: its sinkage past the target by less than one aimed step, the
    hub's travel split into sinkage and deflection, the wheel load that of the last step; the
    fields of tire and soil, and the contact pressures, whose sum over their areas (x 4, quarter
    model) is the wheel load within 10 % (the areas are of the undeformed surface; measured -0.8 %)."""
    scene = _example(tmp_mpi_path, max_sinkage='"0.012 m"')
    out = tmp_mpi_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    tire = summary["tire"]
    assert summary["status"] == "ok" and summary["steps"] >= 2
    assert 0.012 <= tire["sinkage_m"] < 0.012 + 0.004 * 1.524, tire
    assert tire["deflection_m"] > 0 and tire["hub_displacement_m"] == pytest.approx(tire["sinkage_m"]
                                                                                       + tire["deflection_m"])
    assert tire["wheel_load_N"] == pytest.approx(summary["QV_N"], rel=1e-9) and tire["wheel_load_N"] > 0
    # the gas carries most of the load (measured: carcass share 21 % at 6 elements per d)
    assert -0.02 < tire["carcass_load_share"] < 1 and tire["contact_length_m"] > 0
    assert summary["model"]["contact"]["alpha"] == TIRE_PENALTY
    with (out / "history.csv").open() as f:
        assert len(list(csv.DictReader(f))) == summary["steps"]
    for name in summary["files"]["fields"] + summary["files"]["contact_pressure"]:
        assert (out / name).stat().st_size > 0, name
    with (out / "contact_pressure.csv").open() as f:
        rows = list(csv.DictReader(f))
    pressure = np.array([float(r["pressure_Pa"]) for r in rows])
    area = np.array([float(r["area_m2"]) for r in rows])
    assert len(rows) > 4 and pressure.min() > 0
    assert 4 * pressure @ area == pytest.approx(tire["wheel_load_N"], rel=0.1)


def test_pneumatic_continuous_rolling_is_refused_with_the_key(comm, tmp_mpi_path, capsys):
    scene = _example(tmp_mpi_path, protocol='"rolling-continuous"', max_sinkage='"0.01 m"')
    _scene_file(scene, scene.read_text().replace('max_sinkage = "0.01 m"', 'max_sinkage = "0.01 m"\ntravel = "1 m"'))
    assert main(["run", str(scene), "--out", str(tmp_mpi_path / "roll")]) == 2
    assert comm.rank != 0 or "wheel.type" in capsys.readouterr().err        # rank 0 prints the error
    assert not (tmp_mpi_path / "roll").exists()


def _with_load(tmp, load: str, max_sinkage: str) -> pathlib.Path:
    scene = _example(tmp, max_sinkage=max_sinkage)
    text = scene.read_text().replace(f"max_sinkage = {max_sinkage}", f"max_sinkage = {max_sinkage}\nload = {load}")
    return _scene_file(tmp / f"scene_load_{load.strip(chr(34)).replace(' ', '')}.toml", text)


@pytest.mark.slow
def test_pneumatic_scene_pressed_to_a_load(comm, tmp_mpi_path):
    """``loading.load`` presses the tire until the wheel load is reached within 0.1 % (the last
    step found by regula falsi); a load the soil does not carry by ``max_sinkage`` fails with
    the keys to change."""
    out = tmp_mpi_path / "to_load"
    assert main(["run", str(_with_load(tmp_mpi_path, '"20 kN"', '"0.03 m"')), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok"
    assert summary["tire"]["wheel_load_N"] == pytest.approx(20e3, rel=1e-3)
    assert 0 < summary["tire"]["sinkage_m"] < 0.03
    out = tmp_mpi_path / "beyond"
    main(["run", str(_with_load(tmp_mpi_path, '"200 kN"', '"0.004 m"')), "--out", str(out), "--quiet"])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "loading.max_sinkage" in summary["reason"], summary["reason"]
    assert summary["tire"]["sinkage_m"] >= 0.004 and summary["tire"]["wheel_load_N"] < 200e3


def test_rigid_indentation_to_a_load_is_refused_with_the_key(comm, tmp_mpi_path, capsys):
    text = (EXAMPLE.parent / "indentation_mndot.toml").read_text()
    scene = _scene_file(tmp_mpi_path / "rigid_to_load.toml",
                        text.replace('max_sinkage = "0.152 m"', 'max_sinkage = "0.152 m"\nload = "20 kN"'))
    assert main(["run", str(scene), "--out", str(tmp_mpi_path / "rigid")]) == 2
    assert comm.rank != 0 or "loading.load" in capsys.readouterr().err
    assert not (tmp_mpi_path / "rigid").exists()


# ------------------------------------------------------------------------- towed tire
@pytest.mark.slow
def test_towed_tire_on_elastic_soil_rolls_free(comm):
    """The half tire inflated to 450 kPa by full Newton steps, pressed to 30 kN on an elastic soil
    (E = 200 MPa, mu = 0.5; a block 1.7 d x 0.7 d x 0.6 d) and towed 0.1 m in steps of 1/8
    element: every step holds the load within 0.2 % and the axle torque within 0.002 Q d; the
    soil's bottom carries the load (to 1e-6).  Nothing dissipates but the tread's slip, so the
    towing force is nearly zero (measured: within +-0.3 % of the load, mean -0.02 %), and the tire
    turns as a wheel whose rolling radius lies between its loaded radius d/2 - deflection and d/2
    (measured: 0.757 m, d/2 = 0.762 m, deflection 35 mm)."""
    load = 30e3
    tire = pneumatic_tire(D, cut="half", gap=0.03, x_centre=0.6 * D)
    block = rolling_block(D, length=1.7, half_width=0.7, depth=0.6, stiff_length=0.95)
    tm = build_tire_on_soil(comm, tire, block, MeshOptions.from_refinement(D, 6, order=2, hexahedra=True),
                            MeshOptions(SIZE, SIZE, 1.0, order=2))
    pr = PneumaticRolling(tm, tire, VonMises(E=200e6, nu=0.3, yield_stress=1e12), CARCASS, friction=0.5,
                          penalty=TIRE_PENALTY)
    inflation = pr.inflate(PRESSURE)
    # full Newton steps while inflating (95 iterations with the roll's backtracking), then back to it
    assert sum(r.iterations for r in inflation) < 40, inflation
    assert pr.problem.petsc_options["snes_linesearch_type"] == "bt"
    pr.touch()
    assert pr.press_to_load(load, 0.01 * D, 0.1) == "ok"
    deflection = pr.tire_state()["deflection_m"]
    steps = []
    pr.roll_at_load(load, 0.1, 0.125 * D / 6, on_step=steps.append)
    assert len(steps) >= 3 and pr.travel == pytest.approx(0.1)
    for st in steps:
        assert abs(st.QV / load - 1) <= 1.01 * pr.load_rtol, st
        assert abs(st.moment) <= 1.01 * pr.moment_rtol * load * D, st
    w = fem.Function(pr.problem.V)
    w.sub(2).interpolate(lambda x: np.where(np.isclose(x[2], -block.depth), 1.0, 0.0))
    assert pr.factor * pr.problem.internal_force(w) == pytest.approx(pr.wheel_load(), rel=1e-6)
    towing = np.array([st.QH for st in steps]) / load
    assert np.abs(towing).max() < 0.02 and abs(towing.mean()) < 0.005, towing
    radius = pr.rolling_radius(0.0)
    assert D / 2 - deflection < radius < D / 2, (radius, deflection)


@pytest.mark.end_to_end
def test_towed_tire_scene_runs_end_to_end(comm, tmp_mpi_path):
    """``rollsim run`` of the towed-tire example (6 elements per d, 0.07 m of travel): exit 0; the
    history holds the press and the rolled steps; summary.json has the tire's figures, the travel,
    the rotation and the rolling radius; the load is held."""
    text = (EXAMPLE.parent / "pneumatic_rolling.toml").read_text()
    text = re.sub(r'(?m)^travel = .*$', 'travel = "0.07 m"', text) + "refinement = 6\n"
    scene = _scene_file(tmp_mpi_path / "towed.toml", text)
    out = tmp_mpi_path / "towed"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok", summary["reason"]
    assert summary["travel_m"] == pytest.approx(0.07)
    assert summary["rotation_rad"] > 0.8 * 0.07 / (D / 2)
    assert summary["QV_N"] == pytest.approx(40e3, rel=3e-3)
    assert summary["tire"]["sinkage_m"] > 0 and summary["tire"]["deflection_m"] > 0
    assert summary["steady_state"]["reached"] is False
    with (out / "history.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == summary["steps"] and float(rows[-1]["travel_m"]) == pytest.approx(0.07)
    assert [int(r["step"]) for r in rows] == list(range(1, len(rows) + 1))
    for name in ["rolling.png", *summary["files"]["contact_pressure"]]:
        assert (out / name).stat().st_size > 0, name
    # lifted off at the end (the tire's figures are those before): the elastic stiff zone it rolled
    # on springs back, and the path on the test soil is too short for a rut
    profile = np.loadtxt(out / summary["files"]["rut_profile"], delimiter=",", skiprows=1)
    x0 = summary["model"]["x_start_m"]
    rolled = (profile[:, 0] > x0) & (profile[:, 0] < x0 + summary["travel_m"])
    assert rolled.sum() >= 1 and np.abs(profile[rolled, 1]).max() < 0.1 * summary["tire"]["sinkage_m"]
    assert summary["rut_depth_m"] is None and "not rolled far enough" in summary["rut_note"]
