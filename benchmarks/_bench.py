"""Helpers shared by the benchmark scripts (run as ``python benchmarks/<script>.py``)."""
from __future__ import annotations

import argparse
import json

import numpy as np

from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, VOLUMETRIC_STRAINS


def dump_json(comm, path: str | None, payload: dict) -> None:
    """Write ``payload`` (plus the number of ranks) to ``path`` as JSON from rank 0 (no-op without a path)."""
    if comm.rank == 0 and path:
        with open(path, "w") as f:
            json.dump({**payload, "ranks": comm.size}, f, indent=1, default=float)


def add_volumetric_strain(parser: argparse.ArgumentParser,
                          help: str = "pointwise (default, the documented figures) or cell-average (B-bar)") -> None:
    """``--volumetric-strain``: the soil's strain (the solver classes' default, pointwise, unless given)."""
    parser.add_argument("--volumetric-strain", choices=VOLUMETRIC_STRAINS, default=DEFAULT_VOLUMETRIC_STRAIN,
                        help=help)


def read_at(s: np.ndarray, q: np.ndarray, r: float, half: float) -> float:
    """``q`` at ``s = r`` from a rolling run: a least-squares line through the steps with
    ``|s - r| <= half`` (averages out the fast mesh's +-5-10 % step-to-step ripple), or linear
    interpolation when fewer than 3 steps lie there."""
    near = np.abs(s - r) <= half
    if half > 0 and near.sum() >= 3:
        return float(np.polyval(np.polyfit(s[near], q[near], 1), r))
    return float(np.interp(r, s, q))
