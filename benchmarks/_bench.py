"""Helpers shared by the benchmark scripts (run as ``python benchmarks/<script>.py``)."""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys

import numpy as np

from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, VOLUMETRIC_STRAINS


def dump_json(comm, path: str | None, payload: dict) -> None:
    """Write ``payload`` (plus the number of ranks) to ``path`` as JSON from rank 0 (no-op without a path)."""
    if comm.rank == 0 and path:
        with open(path, "w") as f:
            json.dump({**payload, "ranks": comm.size}, f, indent=1, default=float)


def saved_results(paths) -> list[dict]:
    """The ``results`` rows of the JSON files ``paths`` (written by :func:`dump_json`), in order;
    a single path that does not exist yet gives none (a sweep to resume)."""
    paths = [paths] if isinstance(paths, (str, pathlib.Path)) else list(paths)
    return [r for path in paths if path and pathlib.Path(path).exists()
            for r in json.loads(pathlib.Path(path).read_text())["results"]]


def add_results_arguments(parser: argparse.ArgumentParser) -> None:
    """``--table JSON ...`` (print the table of saved results and stop) and ``--out`` (the JSON file
    a sweep resumes from and saves to after each run)."""
    parser.add_argument("--table", nargs="+", metavar="JSON", help="print the table of saved results and stop")
    parser.add_argument("--out")


def show_table(comm, table, results: list[dict]) -> int:
    """Print ``table(results)`` from rank 0; returns 0 (a benchmark's exit status)."""
    if comm.rank == 0:
        print(table(results), flush=True)
    return 0


def run_in_mpirun(ranks: int, argv: list[str], out: pathlib.Path) -> dict | None:
    """Run ``python argv`` under ``mpirun -n ranks`` (a process of its own: its wall time and memory
    alone) and return the JSON it wrote to ``out`` (then removed), or ``None`` after a message
    when it failed."""
    done = subprocess.run(["mpirun", "-n", str(ranks), sys.executable, *argv],
                          env=os.environ | {"OMPI_MCA_rmaps_base_oversubscribe": "1"})
    if done.returncode != 0 or not out.exists():
        print(f"  run failed (exit status {done.returncode}); continuing", flush=True)
        return None
    run = json.loads(out.read_text())
    out.unlink()
    return run


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


#: observed orders outside this range mean the levels are not in the asymptotic range (or their
#: differences are ripple): the benchmarks do not extrapolate then
ORDER_RANGE = (0.5, 4.0)


def observed_order(h: list[float], f: list[float]) -> tuple[float, float] | None:
    """Order ``p`` and extrapolated value of ``f(h) = f0 + C h^p`` through three levels (fine to
    coarse ``h``), or ``None`` when the changes alternate in sign or vanish (no monotone
    convergence to extrapolate).  The generalised three-level formula of Celik et al., J. Fluids
    Eng. 130 (2008) 078001, for unequal refinement ratios."""
    e21, e32 = f[1] - f[0], f[2] - f[1]
    if e21 == 0 or e32 == 0 or e32 / e21 < 0:
        return None
    r21, r32 = h[1] / h[0], h[2] / h[1]
    p = 1.0
    for _ in range(200):            # fixed point of p = |ln|e32/e21| + ln((r21^p - 1)/(r32^p - 1))| / ln r21
        p_new = abs(math.log(abs(e32 / e21)) + math.log((r21 ** p - 1) / (r32 ** p - 1))) / math.log(r21)
        if abs(p_new - p) < 1e-10:
            break
        p = p_new
    return p, f[0] + (f[0] - f[1]) / (r21 ** p - 1)


def run_problems(problems: dict, doc: str, argv: list[str] | None = None) -> int:
    """A benchmark of several problems: ``python -m benchmarks NAME PROBLEM [ARGS]`` runs
    ``problems[PROBLEM](ARGS)`` (each parses its own options); without a problem or with
    ``--help``, the benchmark's docstring ``doc``; an unknown problem exits 2 naming the choices."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(doc.strip())
        return 0
    if argv[0] not in problems:
        print(f"no problem {argv[0]!r}; one of: {', '.join(problems)}", file=sys.stderr)
        return 2
    return problems[argv[0]](argv[1:]) or 0
