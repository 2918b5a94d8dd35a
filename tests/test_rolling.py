"""Towed rigid wheel, protocol rolling-continuous (solver/rolling.py): half model, torque balance, MPI.

Tiny variants (fast preset on a short, narrow block, 0.1 d of travel); the report-size case, the
bearing-capacity comparison and the ramp-rate effect are in benchmarks/bench_rolling.py.
"""
from __future__ import annotations

import csv
import json

import pytest
from mpi4py import MPI

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.scene import parse_scene
from rollsim.solver import VonMises
from rollsim.solver.rolling import WheelRolling, run_rolling
from rollsim.solver.run import HISTORY_COLUMNS
from rollsim.solver.stepping import StepControl

D, B = 1.524, 0.4572          # report wheel
GAMMA = 20e3
BLOCK = {"length": 1.2, "half_width": 0.8, "depth": 0.8}     # in d: short block for tests
CLAY = VonMises(E=40e6, nu=0.35, yield_stress=200e3)          # report case 2 (c = 100 kPa)


def _tiny(comm):
    return build_soil_block(comm, rolling_block(D, stiff_length=0, **BLOCK), MeshOptions.from_accuracy(D, "fast"))


def _scene(friction=0.0, loading=None):
    return parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": friction},
                        "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "von-mises", "E": "40 MPa", "nu": 0.35,
                                                                   "c_dp": "200 kPa"}]},
                        "loading": loading or {"protocol": "rolling-continuous", "max_sinkage": 0.02 * D,
                                               "travel": 0.1 * D},
                        "model": {"accuracy": "fast"}})


def test_frictionless_rolling_run_directory(comm, tmp_mpi_path):
    """run_rolling writes the run directory; frictionless: zero axle moment (normal pressures pass
    through the axle), rolling resistance Q_H > 0, Q_V grows from the initial press as the sinkage
    is ramped, travel_m filled, whole-wheel forces (half model x 2)."""
    scene = _scene(0.0)
    summary = run_rolling(scene, tmp_mpi_path, comm, progress=False, write_fields=False, block=BLOCK,
                          initial_sinkage=0.01 * D)
    assert summary["status"] == "ok", summary.get("reason")
    assert summary["model"]["symmetry"] == "half" and summary["model"]["symmetry_factor"] == 2
    assert summary["travel_m"] == pytest.approx(0.1 * D)
    assert summary["sinkage_m"] == pytest.approx(0.02 * D)
    assert summary["QH_N"] > 0
    assert summary["ranks"] == comm.size and summary["newton_iterations"] > 0
    if comm.rank == 0:
        s = json.loads((tmp_mpi_path / "summary.json").read_text())
        assert s["status"] == "ok" and s["scene"] == scene.to_dict()
        rows = list(csv.DictReader((tmp_mpi_path / "history.csv").open()))
        assert list(rows[0]) == HISTORY_COLUMNS and len(rows) == s["steps"]
        rolled = [r for r in rows if float(r["travel_m"]) > 0]
        pressed = [r for r in rows if float(r["travel_m"]) == 0]
        assert len(rolled) >= 2 and len(pressed) >= 1
        qv0 = float(pressed[-1]["QV_N"])
        for r in rolled:
            assert abs(float(r["moment_Nm"])) < 1e-8 * float(r["QV_N"]) * D
            assert float(r["QH_N"]) > 0
        assert float(rolled[-1]["QV_N"]) > qv0 > 0
        assert (tmp_mpi_path / "force_sinkage.png").stat().st_size > 1000
        assert not list(tmp_mpi_path.glob(".*.tmp"))
    comm.barrier()


def test_towed_wheel_torque_balance(comm):
    """mu = 0.8: the rotation increment of every rolling step is found from zero axle torque
    (|M| <= 2e-3 Q_V d), which needs more than one trial (the no-slip guess leaves a moment);
    the towed wheel skids a little (0 < slip < 0.5); Q_V grows with the sinkage; Q_H > 0."""
    roll = WheelRolling(_tiny(comm), CylinderWheel(D, B, B / 12), CLAY, gamma=GAMMA, friction=0.8)
    assert roll.factor == 2
    roll.gravity_step()
    roll.press(0.01 * D)
    qv_press = roll.steps[-1].QV
    roll.roll(0.1 * D, 0.02 * D)
    rolled = [st for st in roll.steps if st.travel > 0]
    assert len(rolled) >= 2
    assert rolled[-1].travel == pytest.approx(0.1 * D) and rolled[-1].sinkage == pytest.approx(0.02 * D)
    for st in rolled:
        assert abs(st.moment) <= roll.moment_rtol * st.QV * D, st
        assert 0.0 < st.slip < 0.5, st
        assert st.QH > 0
    assert max(st.trials for st in rolled) >= 2
    assert rolled[-1].rotation > 0
    assert rolled[-1].QV > qv_press > 0


def test_partition_independent_rolling(comm):
    """The distributed run equals a serial run on COMM_SELF (mpirun -n 2), friction included."""
    if comm.size == 1:
        pytest.skip("needs mpirun -n >= 2 (compares the distributed run with a COMM_SELF run)")
    res = {}
    for name, cm in (("par", comm), ("ser", MPI.COMM_SELF)):
        roll = WheelRolling(_tiny(cm), CylinderWheel(D, B, B / 12), CLAY, gamma=GAMMA, friction=0.8)
        roll.gravity_step()
        roll.press(0.01 * D, control=StepControl(dt=1.0, dt_max=1.0, dt_min=1e-3))
        roll.roll(0.05 * D, 0.012 * D, dx=0.04)
        res[name] = roll
    par, ser = res["par"], res["ser"]
    assert par.n_dofs == ser.n_dofs
    assert [s.iterations for s in par.steps] == [s.iterations for s in ser.steps]
    for a, b in zip(par.steps, ser.steps):
        assert a.QV == pytest.approx(b.QV, rel=1e-7)
        assert a.QH == pytest.approx(b.QH, abs=1e-7 * abs(b.QV))
        assert a.rotation == pytest.approx(b.rotation, rel=1e-7, abs=1e-12)


def test_other_protocols_refused(comm, tmp_mpi_path):
    with pytest.raises(ValueError, match="loading.protocol"):
        run_rolling(_scene(0.0, {"protocol": "rolling-constant-load", "load": "133.5 kN", "travel": "1 m"}), tmp_mpi_path, comm, progress=False)
