"""``python -m rollsim.geometry``: build a named example or a soil block, write .msh, XDMF and PNG.

  python -m rollsim.geometry example rolling --accuracy fast --out out/geometry
  python -m rollsim.geometry block --cut half --length 3.5 --layers 0.3 --stiff-length 0.75 --out out/b
"""
from __future__ import annotations

import argparse
import pathlib
from typing import Callable

from mpi4py import MPI

from rollsim import compat
from rollsim.geometry.mesh import ACCURACY_REFINEMENT, MeshOptions, log
from rollsim.geometry.render import render_msh
from rollsim.geometry.soil import (PlaneStrainBlock, build_plane_strain_block, build_soil_block,
                                   indentation_block, rolling_block)
from rollsim.geometry.tire import build_tire, pneumatic_tire
from rollsim.geometry.wheels import CylinderWheel, TorusWheel, build_wheel_surface
from rollsim.log import setup_logging

VIEW_SOIL = (1.0, -1.6, 0.9)  # camera from the front-left, above: top, symmetry plane, front
VIEW_QUARTER = (-1.2, -1.6, 1.1)  # camera facing both symmetry planes, where the refined corner is
VIEW_TIRE = (1.0, -1.4, 0.6)  # camera on the cut side: tread section, inner surface

EXAMPLES = {
    "indentation": "quarter indentation block, two layers (top 0.25 d), refined 0.5 d cube under the wheel",
    "rolling": "half rolling block, two layers (top 0.3 d), stiff start zone 0.75 d",
    "tire": "half pneumatic tire (tread 0.046 d), 0.01 d above the soil",
    "plane-strain": "2D plane-strain block with symmetry, contact |x| <= 0.5 d (strip footing B = d)",
    "cylinder-wheel": "rigid cylinder wheel surface (width 0.4 d, fillet 0.05 d)",
    "torus-wheel": "rigid torus wheel surface (width 0.3 d)",
}


def _options(args, hexahedra: bool | None = None) -> MeshOptions:
    refinement = args.refinement or ACCURACY_REFINEMENT[args.accuracy]
    return MeshOptions.from_refinement(args.diameter, refinement, args.order,
                                       args.hexahedra if hexahedra is None else hexahedra)


def _plan_example(args) -> tuple[Callable, tuple]:
    """The validated build of a named example: ``(build(comm, msh) -> TaggedMesh, camera view)``."""
    d = args.diameter
    if args.name == "indentation":
        block, opts = indentation_block(d, layers=(0.25,)), _options(args)
        return lambda comm, msh: build_soil_block(comm, block, opts, msh), VIEW_QUARTER
    if args.name == "rolling":
        block, opts = rolling_block(d, layers=(0.3,)), _options(args)
        return lambda comm, msh: build_soil_block(comm, block, opts, msh), VIEW_SOIL
    if args.name == "tire":
        tire, opts = pneumatic_tire(d), _options(args, hexahedra=True)
        return lambda comm, msh: build_tire(comm, tire, opts, msh), VIEW_TIRE
    if args.name == "plane-strain":
        plane, opts = PlaneStrainBlock(5 * d, 5 * d, 0.5 * d, d, d, symmetric=True), _options(args)
        return lambda comm, msh: build_plane_strain_block(comm, plane, opts, msh), VIEW_SOIL
    wheel = CylinderWheel(d, 0.4 * d, 0.05 * d) if args.name == "cylinder-wheel" else TorusWheel(d, 0.3 * d)
    size = _options(args).fine_size
    return lambda comm, msh: build_wheel_surface(comm, wheel, size, msh), VIEW_TIRE


def _plan_block(args) -> tuple[Callable, tuple]:
    """The validated build of a soil block from flags: ``(build(comm, msh) -> TaggedMesh, view)``."""
    try:
        layers = tuple(float(t) for t in args.layers.split(",")) if args.layers else ()
    except ValueError:
        raise ValueError(f"--layers: expected comma-separated numbers, got {args.layers!r}") from None
    if args.kind == "rolling":
        block = rolling_block(args.diameter, args.length, args.half_width, args.depth, args.cut, layers,
                              args.stiff_length)
    else:
        block = indentation_block(args.diameter, args.half_width, args.depth, args.cut, layers)
    opts = _options(args)
    return lambda comm, msh: build_soil_block(comm, block, opts, msh), VIEW_SOIL


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m rollsim.geometry", description=__doc__.splitlines()[0])
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/geometry"), help="output folder")
    common.add_argument("--diameter", type=float, default=1.0, help="wheel diameter d, m (lengths are in d)")
    common.add_argument("--accuracy", choices=sorted(ACCURACY_REFINEMENT), default="fast")
    common.add_argument("--refinement", type=float, help="elements per d in the refined zone (overrides --accuracy)")
    common.add_argument("--order", type=int, choices=(1, 2), default=1)
    common.add_argument("--hexahedra", action="store_true", help="structured hexahedra / quadrilaterals")
    common.add_argument("--no-png", dest="png", action="store_false", help="skip the picture")
    common.add_argument("-q", "--quiet", action="store_true")
    sub = parser.add_subparsers(dest="command", required=True)
    example = sub.add_parser("example", parents=[common], help="a named example",
                             epilog="; ".join(f"{k}: {v}" for k, v in EXAMPLES.items()))
    example.add_argument("name", choices=sorted(EXAMPLES))
    block = sub.add_parser("block", parents=[common], help="a soil block from flags (lengths in d)")
    block.add_argument("--kind", choices=("rolling", "indentation"), default="rolling")
    block.add_argument("--cut", choices=("full", "half", "quarter"), default="half")
    block.add_argument("--length", type=float, default=3.5, help="rolling block length, d")
    block.add_argument("--half-width", type=float, default=1.5, help="from the wheel mid-plane to the side, d")
    block.add_argument("--depth", type=float, default=1.5, help="d")
    block.add_argument("--layers", default="", help="comma-separated upper layer thicknesses, d")
    block.add_argument("--stiff-length", type=float, default=0.75, help="stiff start zone, d (0: none)")
    block.add_argument("--name", default="block", help="output file stem")
    return parser


def main(argv: list[str] | None = None, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """Build, write ``<out>/<name>.msh``, ``.xdmf`` (mesh + tags) and ``.png``; returns the exit code."""
    args = _parser().parse_args(argv)
    setup_logging(comm, quiet=args.quiet)
    try:  # every flag is checked before anything is written
        build, view = _plan_example(args) if args.command == "example" else _plan_block(args)
    except ValueError as exc:
        log.error("rollsim.geometry: %s", exc)
        return 2
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    msh = args.out / f"{args.name}.msh"
    tagged = build(comm, msh)
    compat.write_tagged_mesh(comm, msh.with_suffix(".xdmf"), tagged.mesh, tagged.cell_tags, tagged.facet_tags)
    log.info("cell tags %s; facet tags %s", tagged.cell_names, tagged.facet_names)
    log.info("wrote %s and %s", msh, msh.with_suffix(".xdmf"))
    if args.png and comm.rank == 0:
        render_msh(msh, msh.with_suffix(".png"), f"{args.name}: {tagged.stats.cells} cells", view)
    comm.barrier()
    return 0
