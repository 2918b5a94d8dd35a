"""Fast variants of the rolling validations (full runs: `python -m benchmarks validation lab`,
`python -m benchmarks rolling protocols`; figures in the docs, "Rolling").

Laboratory rolling on the soft clay (studies/data/lab_rolling.csv): the
small aluminium wheel held at the smallest measured sinkage, on the lab bed's cross-section.
"""
from __future__ import annotations

import csv

import numpy as np
import pytest

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.solver import VonMises
from rollsim.solver.rolling import WheelRolling
from rollsim.studies.bearing_capacity import Soil, Wheel, wheel_forces
from rollsim.studies.design import DATA, LAB_SOILS

LAB_E, LAB_NU = 2.0e6, 0.45                  # clay of the small wheel's tests (docs/validation.md)
BED_HALF_WIDTH, BED_DEPTH = 0.125, 0.100    # m, the lab bed


def _smallest_lab_point(series: str):
    rows = [r for r in csv.DictReader((DATA / "lab_rolling.csv").open()) if r["series"] == series]
    r = min(rows, key=lambda r: float(r["s_mm"]))
    return (float(r["wheel_d_mm"]) / 1e3, float(r["wheel_b_mm"]) / 1e3, float(r["s_mm"]) / 1e3,
            float(r["QV_N"]))


@pytest.mark.slow
def test_lab_small_wheel_held_at_smallest_sinkage(comm):
    """Where the clay's elasticity matters most (s/d = 0.012), steady FE rolling at the held
    sinkage over-predicts the measured force (13 N) but by less than the rigid-plastic model
    (3.2x), and this short hold reads what the benchmark's 1.5 d hold does (35.6 N, 2.7x).
    Frictionless, small strain, fast preset, ramped over 0.5 d and held for 0.5 d on a block
    reaching 0.6 d beyond the end of the travel; Q_V is the mean over the last 0.25 d (6 steps).
    Measured: 35.8 N (35.7 N with a 0.75 d hold and 1 d beyond the travel)."""
    d, b, s_hold, q_lab = _smallest_lab_point("clay_small")
    c, _, gamma = LAB_SOILS["clay_small"]
    hold = 0.5
    blk = rolling_block(d, length=0.4 + 0.5 + hold + 0.6, half_width=BED_HALF_WIDTH / d, depth=BED_DEPTH / d,
                        stiff_length=0.0)
    tm = build_soil_block(comm, blk, MeshOptions.from_accuracy(d, "fast"))
    roll = WheelRolling(tm, CylinderWheel(d, b, b / 12), VonMises(E=LAB_E, nu=LAB_NU, yield_stress=2 * c),
                        gamma=gamma, friction=0.0)
    roll.gravity_step()
    roll.press(0.002 * d)
    roll.roll((0.5 + hold) * d, s_hold, ramp=0.5 * d)
    late = [st.QV for st in roll.steps if st.travel >= (0.5 + 0.5 * hold) * d]
    assert len(late) >= 3
    fe = float(np.mean(late))
    model = float(wheel_forces(s_hold, Wheel(d, b), Soil(c, 0.0, gamma)).QV)
    assert model / q_lab == pytest.approx(3.20, abs=0.01)           # docs/validation.md
    assert q_lab < fe < model, (fe, model, q_lab)
    assert fe == pytest.approx(35.6, rel=0.03)       # the benchmark's 1.5 d hold (35.6 +- 0.4 N); 35.8 N here
