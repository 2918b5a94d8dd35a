"""DOLFINx calls whose API changed after 0.5 live in rollsim/compat.py only, so that a port to a
later DOLFINx is a change of that one module.

The scan reads the code's tokens (comments and strings do not count) of every Python file of the
package, the benchmarks and the tests.
"""
from __future__ import annotations

import io
import pathlib
import re
import tokenize

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
FOLDERS = ("rollsim", "geometry", "solver", "studies", "benchmarks", "tests")
COMPAT = ROOT / "rollsim" / "compat.py"

#: pattern -> what changed after DOLFINx 0.5
VERSION_SPECIFIC = {
    r"\.links\(": "dofmap adjacency lists became 2D arrays (0.7)",
    r"\.list\.array\b|dofmap\.list\b": "dofmap adjacency lists became 2D arrays (0.7)",
    r"\bgeometry\.dofmap\.array\b": "geometry dofmap became a 2D array (0.7)",
    r"\bcompute_incident_entities\b": "takes the topology instead of the mesh (0.7)",
    r"\.vector\b": "Function.vector became Function.x.petsc_vec (0.8)",
    r"\.cell_name\(\)": "topology.cell_name() became cell_type.name (0.7)",
    r"\b(?:Vector|Tensor)?FunctionSpace\(": "FunctionSpace / VectorFunctionSpace became functionspace (0.7)",
    r"\bufl\.(?:Finite|Vector|Tensor|Mixed)Element\b": "elements moved to basix.ufl (0.7)",
    r"\bfem\.Expression\(": "Expression's arguments changed (0.7)",
    r"\bgmshio\b": "gmshio.model_to_mesh returns a MeshData object (0.10)",
    r"\bNewtonSolver\b": "NewtonSolver moved to dolfinx.nls.petsc with a new constructor (0.8)",
    r"\bcreate_vtk_mesh\b": "plot.create_vtk_mesh became vtk_mesh (0.7)",
    r"\bBoundingBoxTree\b|\bcompute_collisions\(": "bb_tree / compute_collisions_points (0.7)",
    r"\bcreate_meshtags\b": "create_meshtags became meshtags (0.6)",
    r"\bdolfinx\.cpp\b|\b_cpp\.": "the C++ bindings are not a stable API",
    r"(?<!compat\.)\bcreate_vector\(": "fem.petsc.create_vector takes the function space (0.10)",
    r"(?<!compat\.)\b(?:apply_lifting|set_bc)\(": "the scale argument became alpha (0.8)",
    r"\binterpolation_points\(\)": "interpolation_points became a property (0.7)",
}


def _code(path: pathlib.Path) -> list[tuple[int, str]]:
    """``(line number, code)`` of ``path`` without comments and string literals."""
    lines: dict[int, list[str]] = {}
    for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
        if tok.type in (tokenize.COMMENT, tokenize.STRING, tokenize.NL, tokenize.NEWLINE):
            continue
        lines.setdefault(tok.start[0], []).append(tok.string)
    return [(n, "".join(parts)) for n, parts in sorted(lines.items())]


def _offences(paths, root: pathlib.Path = ROOT) -> list[str]:
    """``"file:line: what changed"`` for every version-specific call in ``paths``."""
    found = []
    for path in paths:
        for number, code in _code(path):
            for pattern, why in VERSION_SPECIFIC.items():
                if re.search(pattern, code):
                    found.append(f"{path.relative_to(root)}:{number}: {why}")
    return found


def _sources() -> list[pathlib.Path]:
    files = [p for folder in FOLDERS for p in sorted((ROOT / folder).rglob("*.py"))]
    return [p for p in files if p != COMPAT and p != pathlib.Path(__file__).resolve()]


def test_version_specific_calls_only_in_compat():
    found = _offences(_sources())
    assert not found, "DOLFINx-version-specific calls outside rollsim/compat.py:\n" + "\n".join(found)


def test_the_scan_finds_them(tmp_path):
    """The scan is not blind: compat.py itself has them, and a planted call is found (a comment or
    string naming one is not)."""
    assert len(_offences([COMPAT])) >= 5
    planted = tmp_path / "planted.py"
    planted.write_text("x = u.vector.copy()  # u.vector\ny = 'V.dofmap.list.array'\nz = compat.set_bc(b, bcs)\n")
    assert _offences([planted], tmp_path) == ["planted.py:1: Function.vector became Function.x.petsc_vec (0.8)"]


@pytest.mark.parametrize("call", ["fem.Expression(e, pts)", "mesh.topology.cell_name()", "V.dofmap.links(0)",
                                  "compute_incident_entities(msh, f, 2, 3)"])
def test_patterns_match_known_calls(call):
    assert any(re.search(p, call) for p in VERSION_SPECIFIC), call
