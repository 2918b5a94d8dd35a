"""Side by side with CalculiX: a rigid cylinder pressed into a von Mises block, with friction.

    python -m benchmarks peer_calculix                          # 8 and 12 elements / d, 1 and 2 ranks
    python -m benchmarks peer_calculix --refinement 8 --ranks 1  # one level, serial
    python -m benchmarks peer_calculix --report                  # table from the saved JSON

The problem: the Mn/DOT wheel (d = 1.524 m, b = 0.4572 m, edge fillet b/12) on the report case-2
soil (E = 40 MPa, nu = 0.35, von Mises q_y = 200 kPa), Coulomb friction mu = 0.8, weightless
soil (CalculiX has no geostatic initial-stress step to match rollsim's), quarter model, pushed
down to s/d = 0.05 in equal steps of s/d = 0.0025; Q_V is read at s/d = 0.02 and 0.05.

Both codes solve the same gmsh mesh: rollsim meshes the quarter block (P2 tetrahedra), and the
benchmark writes that mesh to a CalculiX deck as C3D10 elements (the same quadratic tetrahedra,
mid-side nodes on the straight edges).  The wheel in CalculiX is a one-layer C3D8 shell of its
contact sector (faceted every 1 deg, fillet included) whose nodes all follow the prescribed
wheel displacement (a rigid wheel that does not rotate, as in rollsim); contact is CalculiX's
face-to-face penalty with the normal and tangential stiffness rollsim uses (``kappa = alpha E /
h``, read from the rollsim run on the same mesh), friction ``*FRICTION``.  Both codes are
geometrically linear (no ``NLGEOM``) with contact on the deformed surface.  What differs is the
element integration: CalculiX's C3D10 takes 4 points and the plain strain; rollsim takes its
``--volumetric-strain`` (B-bar, the indentation default, and pointwise are both run).

Each rollsim run is its own ``mpirun`` process (1 and 2 ranks); CalculiX runs with 1 and 2
threads (``OMP_NUM_THREADS``, ``CCX_NPROC_EQUATION_SOLVER``).  Results are appended to
``--results`` (JSON); runs already there are not repeated.  CalculiX (Debian ``calculix-ccx``) is
not part of rollsim's install: when ``ccx`` is missing the benchmark installs it with apt-get when
it can (root) and otherwise skips the CalculiX runs with a message.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
RESULTS = HERE / "results" / "peer_calculix.json"
D, B = 1.524, 0.4572                        # Mn/DOT wheel, m
FILLET = B / 12
E, NU, YIELD = 40e6, 0.35, 200e3           # report case 2 soil (Pa)
MU = 0.8
STEP = 0.0025                               # s/d of every step
READ = (0.02, 0.05)                         # s/d of the readings
STRAINS = ("cell-average", "pointwise")
WHEEL_SECTOR = 40.0                         # deg of wheel rim modelled in CalculiX (contact: < 27 deg at s/d 0.05)
FACET_DEG = 1.0                             # deg per wheel facet along the rim
SYMMETRY_FACTOR = 4                         # quarter model: whole-wheel force / modelled part
CCX_TIME_LIMIT = 4 * 3600.0                 # s: a CalculiX run stopped after this is recorded as failed


# ---------------------------------------------------------------------------------------------- rollsim
def rollsim_run(comm, refinement: float, strain: str) -> dict:
    """One rollsim push (on ``comm``): Q_V at the readings, cost, and the contact stiffnesses."""
    import bench_indentation as indentation
    from rollsim.solver import VonMises
    res = indentation.run(comm, f"{refinement:g}", VonMises(E=E, nu=NU, yield_stress=YIELD), D, B, 0.0, MU,
                          s_end=READ[-1], volumetric_strain=strain, step=STEP)
    return {"code": "rollsim", "refinement": refinement, "parallel": comm.size, "volumetric_strain": strain,
            "status": res["status"], "cells": res["cells"], "dofs": res["dofs"], "steps": res["steps"],
            "iterations": res["newton_iterations"], "cuts": res["cuts"], "time_s": res["time_s"],
            "QV": {f"{r:g}": res["QV"].get(f"{r:g}") for r in READ},
            "contact_stiffness": res["contact_stiffness"]}


# ---------------------------------------------------------------------------------------------- CalculiX deck
def soil_mesh(refinement: float, msh_path: pathlib.Path):
    """The quarter block rollsim meshes at ``refinement``, as written by gmsh: corner nodes (N, 3),
    tetrahedra (M, 4, positive volume) and the corner nodes of each named boundary."""
    import gmsh
    from mpi4py import MPI
    from rollsim.geometry import MeshOptions, build_soil_block, indentation_block
    build_soil_block(MPI.COMM_SELF, indentation_block(D), MeshOptions.from_refinement(D, refinement), msh_path=msh_path)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(msh_path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1)
        index[tags.astype(int)] = np.arange(tags.size)
        types, _, nodes = gmsh.model.mesh.getElements(3)
        if list(types) != [4]:
            raise RuntimeError(f"expected linear tetrahedra (gmsh type 4), got types {list(types)}")
        tets = index[nodes[0].astype(int)].reshape(-1, 4)
        boundaries = {}
        for dim, tag in gmsh.model.getPhysicalGroups(2):
            name = gmsh.model.getPhysicalName(dim, tag)
            on_group = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)[0]
            boundaries[name] = np.unique(index[on_group.astype(int)])
    finally:
        gmsh.finalize()
    x = xyz.reshape(-1, 3)
    a, b, c = (x[tets[:, k]] - x[tets[:, 0]] for k in (1, 2, 3))
    flip = np.einsum("ij,ij->i", np.cross(a, b), c) < 0
    tets[flip, 1], tets[flip, 2] = tets[flip, 2], tets[flip, 1].copy()
    return x, tets, boundaries


#: C3D10 edge order (after the 4 corners) and the corner triples of the faces S1-S4
C3D10_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
TET_FACES = ((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0))


def quadratic_tets(x: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Mid-side nodes on the straight edges: nodes (N', 3), C3D10 connectivity (M, 10) and the
    mid-side node of each corner pair."""
    mids: dict[tuple[int, int], int] = {}
    extra = []
    conn = np.empty((len(tets), 10), dtype=int)
    conn[:, :4] = tets
    for e, tet in enumerate(tets):
        for k, (i, j) in enumerate(C3D10_EDGES):
            key = (min(tet[i], tet[j]), max(tet[i], tet[j]))
            if key not in mids:
                mids[key] = len(x) + len(extra)
                extra.append(0.5 * (x[key[0]] + x[key[1]]))
            conn[e, 4 + k] = mids[key]
    return np.vstack([x, np.array(extra)]), conn, mids


def wheel_shell(first_node: int, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """One layer of C3D8 bricks under the rim of the quarter wheel (centre (0, 0, d/2), axle along
    y, rim from the bottom forward by WHEEL_SECTOR deg, y from 0 to b/2 with the fillet): nodes (N,
    3) and connectivity (M, 8) with node ids from ``first_node`` on, face S1 on the wheel surface."""
    r = D / 2
    flat = np.linspace(0.0, B / 2 - FILLET, 9)
    beta = np.linspace(0.0, np.pi / 2, 9)[1:]
    profile = np.vstack([np.column_stack([np.full_like(flat, r), flat]),
                         np.column_stack([r - FILLET + FILLET * np.cos(beta), B / 2 - FILLET + FILLET * np.sin(beta)])])
    alpha = np.radians(np.linspace(0.0, WHEEL_SECTOR, int(round(WHEEL_SECTOR / FACET_DEG)) + 1))
    na, npf = len(alpha), len(profile)
    pts = np.empty((2, na, npf, 3))
    for k, inset in enumerate((0.0, thickness)):
        rho = profile[:, 0] - inset
        pts[k, :, :, 0] = np.outer(np.sin(alpha), rho)
        pts[k, :, :, 1] = profile[None, :, 1]
        pts[k, :, :, 2] = r - np.outer(np.cos(alpha), rho)
    ids = first_node + np.arange(pts[..., 0].size).reshape(2, na, npf)
    bricks = []
    for i in range(na - 1):
        for j in range(npf - 1):
            quad = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            outer = [ids[0][q] for q in quad]
            inner = [ids[1][q] for q in quad]
            bricks.append(outer + inner)
    bricks = np.array(bricks)
    xyz = pts.reshape(-1, 3)
    loc = bricks - first_node
    a, b, c = (xyz[loc[:, k]] - xyz[loc[:, 0]] for k in (1, 3, 4))
    if np.einsum("ij,ij->i", np.cross(a, b), c).min() < 0:   # S1 (nodes 1-4) must face out of the brick
        bricks = bricks[:, [0, 3, 2, 1, 4, 7, 6, 5]]
    return xyz, bricks


def _lines(values, per_line: int = 16) -> str:
    v = [str(int(k)) for k in values]
    return "\n".join(", ".join(v[i:i + per_line]) for i in range(0, len(v), per_line))


def calculix_deck(refinement: float, contact_stiffness: tuple[float, float], workdir: pathlib.Path) -> dict:
    """Write ``workdir/indent.inp`` for the quarter block at ``refinement`` (supports: rollsim's own
    normal-displacement conditions per boundary); returns the mesh sizes."""
    from rollsim.solver.indentation import _NORMAL_COMPONENT as NORMAL_COMPONENT
    x, tets, boundaries = soil_mesh(refinement, workdir / "soil.msh")
    nodes, conn, mids = quadratic_tets(x, tets)

    def with_mids(corners: np.ndarray) -> np.ndarray:
        s = set(corners.tolist())
        return np.array(sorted(s | {m for (i, j), m in mids.items() if i in s and j in s}))

    wheel_xyz, bricks = wheel_shell(len(nodes), thickness=0.05 * D)
    out = ["** rollsim peer benchmark: rigid cylinder on a von Mises block (quarter model)", "*NODE, NSET=NALL"]
    out += [f"{i + 1}, {p[0]:.12g}, {p[1]:.12g}, {p[2]:.12g}" for i, p in enumerate(nodes)]
    out += [f"{len(nodes) + i + 1}, {p[0]:.12g}, {p[1]:.12g}, {p[2]:.12g}" for i, p in enumerate(wheel_xyz)]
    out += ["*ELEMENT, TYPE=C3D10, ELSET=SOIL"]
    out += [f"{e + 1}, " + ", ".join(str(n + 1) for n in c) for e, c in enumerate(conn)]
    out += ["*ELEMENT, TYPE=C3D8, ELSET=WHEEL"]
    out += [f"{len(conn) + e + 1}, " + ", ".join(str(n + 1) for n in c) for e, c in enumerate(bricks)]
    supports = [(name, comp + 1) for name, comp in NORMAL_COMPONENT[3].items() if name in boundaries]
    for name, _ in supports:
        out += [f"*NSET, NSET={name.upper()}", _lines(with_mids(boundaries[name]) + 1)]
    out += ["*NSET, NSET=WHEELNODES", _lines(len(nodes) + 1 + np.arange(len(wheel_xyz)))]
    # slave: the soil's top faces in reach of the wheel sector
    on_top = np.abs(nodes[:, 2]) < 1e-9 * D
    reach_x, reach_y = D / 2 * np.sin(np.radians(WHEEL_SECTOR)) + 0.1 * D, B / 2 + 0.1 * D
    slave = []
    for e, tet in enumerate(tets):
        for f, face in enumerate(TET_FACES):
            corners = tet[list(face)]
            if on_top[corners].all() and nodes[corners, 0].min() < reach_x and nodes[corners, 1].min() < reach_y:
                slave.append(f"{e + 1}, S{f + 1}")
    out += ["*SURFACE, NAME=SOILTOP, TYPE=ELEMENT", *slave]
    out += ["*SURFACE, NAME=RIM, TYPE=ELEMENT", *(f"{len(conn) + e + 1}, S1" for e in range(len(bricks)))]
    kappa, k_t = contact_stiffness
    out += ["*MATERIAL, NAME=SOIL", "*ELASTIC", f"{E:.12g}, {NU}", "*PLASTIC", f"{YIELD:.12g}, 0.0",
            "*MATERIAL, NAME=STEEL", "*ELASTIC", "2.1e11, 0.3",
            "*SOLID SECTION, ELSET=SOIL, MATERIAL=SOIL", "*SOLID SECTION, ELSET=WHEEL, MATERIAL=STEEL",
            "*CONTACT PAIR, INTERACTION=WHEELSOIL, TYPE=SURFACE TO SURFACE", "SOILTOP, RIM",
            "*SURFACE INTERACTION, NAME=WHEELSOIL", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
            f"{kappa:.12g}", "*FRICTION", f"{MU}, {k_t:.12g}",
            "*BOUNDARY", *(f"{name.upper()}, {dof}, {dof}" for name, dof in supports), "WHEELNODES, 1, 2"]
    s_prev = 0.0
    for s in READ:
        inc = STEP / (s - s_prev)
        out += ["*STEP, INC=1000", "*STATIC", f"{inc:.12g}, 1.0, {inc / 64:.12g}, {inc:.12g}",
                "*BOUNDARY", f"WHEELNODES, 3, 3, {-s * D:.12g}", "*NODE PRINT, NSET=WHEELNODES, TOTALS=ONLY", "RF",
                "*END STEP"]
        s_prev = s
    (workdir / "indent.inp").write_text("\n".join(out) + "\n")
    return {"cells": len(tets), "dofs": 3 * len(nodes), "slave_faces": len(slave), "wheel_facets": len(bricks)}


# ---------------------------------------------------------------------------------------------- CalculiX run
def find_calculix() -> str | None:
    """Path of ``ccx``; installs Debian's calculix-ccx when missing and apt-get can run (root)."""
    if shutil.which("ccx"):
        return shutil.which("ccx")
    if shutil.which("apt-get") and os.geteuid() == 0:
        print("ccx not found: installing calculix-ccx with apt-get ...", flush=True)
        subprocess.run(["apt-get", "install", "-y", "-q", "calculix-ccx"], stdout=subprocess.DEVNULL)
    return shutil.which("ccx")


def reaction_history(dat: str) -> list[tuple[float, float]]:
    """(total time, vertical reaction on the wheel) of every increment in a .dat file."""
    rows = []
    for block in re.finditer(r"total force \(fx,fy,fz\) for set WHEELNODES and time\s+(\S+)\s+\S+\s+\S+\s+(\S+)", dat):
        rows.append((float(block.group(1)), float(block.group(2))))
    return rows


def calculix_run(ccx: str, refinement: float, threads: int, contact_stiffness, keep: pathlib.Path | None) -> dict:
    """Write the deck at ``refinement``, run ``ccx`` on ``threads`` threads and read Q_V at the
    readings, increments, iterations and wall time (working files in ``keep``, else removed)."""
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="rollsim-ccx-")) if keep is None else keep
    workdir.mkdir(parents=True, exist_ok=True)
    try:
        sizes = calculix_deck(refinement, contact_stiffness, workdir)
        env = os.environ | {"OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads),
                            "CCX_NPROC_RESULTS": str(threads), "CCX_NPROC_STIFFNESS": str(threads)}
        t0 = time.perf_counter()
        try:
            done = subprocess.run([ccx, "-i", "indent"], cwd=workdir, env=env, capture_output=True, text=True,
                                  timeout=CCX_TIME_LIMIT)
        except subprocess.TimeoutExpired as err:
            done = subprocess.CompletedProcess(err.cmd, -1, "", f"stopped after {CCX_TIME_LIMIT:.0f} s")
        wall = time.perf_counter() - t0
        (workdir / "ccx.log").write_text(done.stdout + done.stderr)
        dat = (workdir / "indent.dat").read_text() if (workdir / "indent.dat").exists() else ""
        history = reaction_history(dat)
        sta = (workdir / "indent.sta").read_text().splitlines() if (workdir / "indent.sta").exists() else []
        incs = [ln.split() for ln in sta if re.match(r"\s*\d+\s+\d+\s+\d+\s+\d+", ln)]
        # s/d at total time t: step k ramps from READ[k-1] to READ[k] over t in (k-1, k]
        qv = {}
        for t, rf in history:
            k = min(int(np.ceil(t - 1e-9)), len(READ)) - 1
            lo = READ[k - 1] if k > 0 else 0.0
            s = lo + (t - k) * (READ[k] - lo)
            for r in READ:
                if abs(s - r) < 1e-6:
                    qv[f"{r:g}"] = -SYMMETRY_FACTOR * rf
        ok = done.returncode == 0 and len(qv) == len(READ)
        status = "ok" if ok else f"failed: exit {done.returncode}, {(done.stdout + done.stderr).strip()[-200:]}"
        return {"code": "calculix", "refinement": refinement, "parallel": threads, "volumetric_strain": "C3D10",
                "status": status, **sizes, "steps": len(incs),
                "iterations": sum(int(r[3]) for r in incs), "cuts": sum(int(r[2]) - 1 for r in incs),
                "time_s": wall, "QV": qv, "contact_stiffness": list(contact_stiffness),
                "curve": [(t, -SYMMETRY_FACTOR * rf) for t, rf in history]}
    finally:
        if keep is None:
            shutil.rmtree(workdir, ignore_errors=True)


# ---------------------------------------------------------------------------------------------- sweep and report
def load(path: pathlib.Path) -> list[dict]:
    return json.loads(path.read_text())["runs"] if path.exists() else []


def save(path: pathlib.Path, run: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"runs": load(path) + [run]}, indent=1, default=float))


def have(runs, code, n, par, strain) -> dict | None:
    return next((r for r in runs if r["code"] == code and r["refinement"] == n and r["parallel"] == par
                 and r["volumetric_strain"] == strain and r["status"] == "ok"), None)


def sweep(args) -> int:
    from _bench import run_in_mpirun
    for n in args.refinement:
        for strain in args.volumetric_strain:
            for ranks in args.ranks:
                if have(load(args.results), "rollsim", n, ranks, strain):
                    continue
                print(f"rollsim, {n:g} elements / d, {strain}, {ranks} rank(s) ...", flush=True)
                one = args.results.parent / f".peer-{n:g}-{strain}-{ranks}.json"
                run = run_in_mpirun(ranks, [__file__, "--one", "--refinement", f"{n:g}",
                                            "--volumetric-strain", strain, "--results", str(one)], one)
                if run is None:
                    continue
                save(args.results, run)
                print(f"  {run['status']}: Q_V {run['QV']}, {run['time_s']:.0f} s", flush=True)
        ccx = find_calculix()
        if ccx is None:
            print("CalculiX (ccx) is not installed and could not be installed (apt-get install calculix-ccx): "
                  "skipping its runs", flush=True)
            continue
        stiffness = next((r["contact_stiffness"] for r in load(args.results)
                          if r["code"] == "rollsim" and r["refinement"] == n), None)
        if stiffness is None:
            print(f"no rollsim run at {n:g} elements / d to take the contact stiffness from: skipping CalculiX")
            continue
        for threads in args.ranks:
            if have(load(args.results), "calculix", n, threads, "C3D10"):
                continue
            print(f"CalculiX, {n:g} elements / d, {threads} thread(s) ...", flush=True)
            run = calculix_run(ccx, n, threads, stiffness, args.keep)
            save(args.results, run)
            print(f"  {run['status'][:200]}: Q_V {run['QV']}, {run['time_s']:.0f} s", flush=True)
    return report(args)


def report(args) -> int:
    runs = [r for r in load(args.results) if r["status"] == "ok"]
    if not runs:
        print(f"no results in {args.results}")
        return 1
    pars = sorted({r["parallel"] for r in runs})
    print("| code | elements / d | strain / element | cells | dofs | " +
          " | ".join(f"Q_V at s/d = {r:g}" for r in READ) + " | steps | Newton its | " +
          " | ".join(f"wall, {p} rank/thread{'s' * (p > 1)}" for p in pars) + " |")
    print("|---" * (7 + len(READ) + len(pars)) + "|")
    keys = sorted({(r["refinement"], r["code"], r["volumetric_strain"]) for r in runs})
    for n, code, strain in keys:
        rr = {r["parallel"]: r for r in runs if (r["refinement"], r["code"], r["volumetric_strain"]) == (n, code, strain)}
        r = rr[min(rr)]
        ccx = have(runs, "calculix", n, min(pars), "C3D10")
        q = []
        for k in READ:
            v = r["QV"].get(f"{k:g}")
            rel = f" ({100 * (v / ccx['QV'][f'{k:g}'] - 1):+.1f} %)" if ccx and code != "calculix" and v else ""
            q.append(f"{v / 1e3:.1f} kN{rel}" if v else "")
        print(f"| {code} | {n:g} | {strain} | {r['cells']} | {r['dofs']} | " + " | ".join(q) +
              f" | {r['steps']} | {r['iterations']} | " +
              " | ".join(f"{rr[p]['time_s']:.0f} s" if p in rr else "" for p in pars) + " |")
    ref = max((r for r in runs if r["code"] == "rollsim" and r["volumetric_strain"] == "cell-average"),
              key=lambda r: r["refinement"], default=None)
    if ref is not None:
        levels = sorted({k[0] for k in keys})
        print(f"\nError of Q_V at s/d = {' / '.join(f'{k:g}' for k in READ)} against rollsim's B-bar at "
              f"{ref['refinement']:g} elements / d (its finest level)\n")
        print("| code | strain / element | " + " | ".join(f"{n:g} / d" for n in levels) + " |")
        print("|---" * (2 + len(levels)) + "|")
        for code, strain in sorted({(k[1], k[2]) for k in keys}):
            cells = []
            for n in levels:
                r = have(runs, code, n, min(pars), strain)
                cells.append(" / ".join(f"{100 * (r['QV'][f'{k:g}'] / ref['QV'][f'{k:g}'] - 1):+.1f} %" for k in READ)
                             if r and r is not ref else "")
            print(f"| {code} | {strain} | " + " | ".join(cells) + " |")
    print()
    for code, strain in sorted({(k[1], k[2]) for k in keys}):
        print(f"- {code} ({strain}), extrapolated from its three finest levels: " + extrapolated(
            [r for r in runs if (r["code"], r["volumetric_strain"], r["parallel"]) == (code, strain, min(pars))]))
    return 0


def extrapolated(runs: list[dict]) -> str:
    """Q_V at each reading from Richardson extrapolation of the three finest levels, with the
    observed order (or why there is none)."""
    from _bench import ORDER_RANGE, observed_order
    fine = sorted(runs, key=lambda r: -r["refinement"])[:3]
    if len(fine) < 3:
        return "fewer than three levels"
    parts = []
    for k in READ:
        fit = observed_order([1 / r["refinement"] for r in fine], [r["QV"][f"{k:g}"] for r in fine])
        if fit is None or not ORDER_RANGE[0] <= fit[0] <= ORDER_RANGE[1]:
            parts.append(f"s/d = {k:g}: no order in {ORDER_RANGE[0]:g}-{ORDER_RANGE[1]:g}")
        else:
            parts.append(f"s/d = {k:g}: {fit[1] / 1e3:.1f} kN (order {fit[0]:.2f})")
    return "; ".join(parts)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--refinement", nargs="+", type=float, default=[8.0, 12.0], help="elements per d under the wheel")
    p.add_argument("--ranks", nargs="+", type=int, default=[1, 2], help="rollsim MPI ranks and CalculiX threads")
    p.add_argument("--volumetric-strain", nargs="+", choices=STRAINS, default=list(STRAINS),
                   help="rollsim's soil strain(s)")
    p.add_argument("--results", type=pathlib.Path, default=RESULTS, help="JSON file of the runs")
    p.add_argument("--keep", type=pathlib.Path, help="directory for the CalculiX deck and output (default: removed)")
    p.add_argument("--report", action="store_true", help="only print the table")
    p.add_argument("--one", action="store_true", help=argparse.SUPPRESS)    # one rollsim run, in a subprocess
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    if any(r < 1 for r in args.ranks) or any(not n > 0 for n in args.refinement):
        print("--ranks: at least 1; --refinement: elements per d > 0", file=sys.stderr)
        return 2
    if args.one:
        from mpi4py import MPI
        comm = MPI.COMM_WORLD
        run = rollsim_run(comm, args.refinement[0], args.volumetric_strain[0])
        if comm.rank == 0:
            args.results.write_text(json.dumps(run, default=float))
        return 0
    if args.report:
        return report(args)
    return sweep(args)


if __name__ == "__main__":
    raise SystemExit(main())
