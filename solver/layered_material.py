"""Several materials in one :class:`PlasticityProblem` (e.g. horizontal soil layers) without
changing the problem: a wrapper that the generic ``return_map`` dispatches to and that splits
the quadrature points by material.

    mat = LayeredMaterial([strong, weak], layer_of=lambda x: (x[:, 1] < -0.5).astype(int))
    fo = StripFooting(mesh, mat)          # StripFooting binds the quadrature points itself
    # or, with a bare PlasticityProblem:  mat.bind_points(quadrature_point_coordinates(problem))

``layer_of(x)`` maps quadrature-point coordinates ``(n, gdim)`` to indices into ``materials``.
Every material keeps its own elasticity in its return map.  The wrapper's own ``E``/``nu`` (used
by the problem only for its initial tangent, the elastic timing reference and the default K0) are
those of ``materials[0]``.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

__all__ = ["LayeredMaterial", "quadrature_point_coordinates"]


class LayeredMaterial:
    def __init__(self, materials: Sequence, layer_of: Callable[[np.ndarray], np.ndarray]):
        if not materials:
            raise ValueError("materials must not be empty")
        self.materials = list(materials)
        self.layer_of = layer_of
        self.index: np.ndarray | None = None
        m0 = self.materials[0]
        self.E, self.nu = m0.E, m0.nu
        self.shear_modulus, self.bulk_modulus = m0.shear_modulus, m0.bulk_modulus
        self.lame_lambda = m0.lame_lambda
        self.cohesion = max(getattr(m, "cohesion", 0.0) for m in self.materials)
        self.tan_phi = max(getattr(m, "tan_phi", 0.0) for m in self.materials)

    def bind_points(self, coords: np.ndarray) -> None:
        """Assign every (owned) quadrature point, in the problem's order, to a material."""
        idx = np.asarray(self.layer_of(np.asarray(coords)), dtype=int)
        if idx.shape != (len(coords),) or idx.min(initial=0) < 0 or idx.max(initial=0) >= len(self.materials):
            raise ValueError("layer_of must return one index into materials per quadrature point")
        self.index = idx

    def _split(self, n: int):
        if self.index is None or len(self.index) != n:
            raise RuntimeError(f"LayeredMaterial is bound to {None if self.index is None else len(self.index)} "
                               f"quadrature points, got {n}: call bind_points first")
        return [(k, np.nonzero(self.index == k)[0]) for k in range(len(self.materials))]

    def return_map(self, sigma_n, deps, tangent: bool = True, rtol: float = 1e-10):
        from .return_map import ReturnResult, return_map
        sigma_n = np.atleast_2d(np.asarray(sigma_n, dtype=float))
        deps = np.atleast_2d(np.asarray(deps, dtype=float))
        n, nc = deps.shape
        out = ReturnResult(sigma=np.empty((n, nc)), tangent=np.empty((n, nc, nc)) if tangent else None,
                           deps_p=np.empty((n, nc)), dlam=np.empty(n), state=np.empty(n, dtype=np.int8))
        for k, sel in self._split(n):
            if sel.size == 0:
                continue
            r = return_map(self.materials[k], sigma_n[sel], deps[sel], tangent=tangent, rtol=rtol)
            out.sigma[sel], out.deps_p[sel], out.dlam[sel], out.state[sel] = r.sigma, r.deps_p, r.dlam, r.state
            if tangent:
                out.tangent[sel] = r.tangent
        return out

    def yield_function(self, sigma):
        from .return_map import yield_function
        sigma = np.atleast_2d(np.asarray(sigma, dtype=float))
        n = len(sigma)
        if self.index is not None and len(self.index) == n:
            f = np.empty(n)
            for k, sel in self._split(n):
                if sel.size:
                    f[sel] = yield_function(self.materials[k], sigma[sel])
            return f
        # unbound or a few probe stresses: the most restrictive material
        return np.max([yield_function(m, sigma) for m in self.materials], axis=0)


def quadrature_point_coordinates(problem) -> np.ndarray:
    """Physical coordinates ``(n_qp, gdim)`` of the owned quadrature points of ``problem``."""
    import ufl
    from dolfinx import fem

    from rollsim import compat
    gdim = problem.gdim
    Q = compat.quadrature_space(problem.mesh, problem.qdeg, (gdim,))
    f = fem.Function(Q)
    X = ufl.SpatialCoordinate(problem.mesh)
    compat.evaluate_into(compat.expression(ufl.as_vector([X[i] for i in range(gdim)]), problem.points), f)
    return f.x.array[: problem.n_qp * gdim].reshape(problem.n_qp, gdim).copy()
