"""Dynamic cone penetrometer (DCP) correlations used by the Mn/DOT report (docs/theory.md).

PR is the penetration rate in mm/blow; the report uses its average over the top 0.5 m.
"""
from __future__ import annotations

import numpy as np

# Ayers et al. (1989): deviatoric stress at failure (kPa) vs PR, per confining pressure (kPa)
AYERS_SAND = {34.4: (285.0, -3.48), 103.0: (692.0, -6.35), 207.0: (1031.0, -3.45)}
AYERS_PR_RANGE = (12.0, 31.0)  # mm/blow where the sand correlation holds


def cbr_from_penetration_rate(pr):
    """CBR (%) from PR (mm/blow), Coonse (1999): CBR = 338.8 PR^-1.14."""
    return 338.8 * np.asarray(pr, dtype=float) ** -1.14


def cohesion_from_penetration_rate(pr):
    """Undrained cohesion (Pa) of near-saturated clay from PR (mm/blow).

    Coonse (1999) CBR with Gregory & Cross (2007) CBR = 0.0929 c[kPa].
    """
    return 1e3 * cbr_from_penetration_rate(pr) / 0.0929


def friction_angle_from_penetration_rate(pr, confining_pressure=103e3):
    """(phi (rad), in_range) of sand from PR (mm/blow), Ayers et al. (1989).

    ``confining_pressure`` (Pa) is one of 34.4, 103 or 207 kPa, or linearly
    interpolated between them; ``in_range`` flags PR within 12-31 mm/blow.
    """
    pr = np.asarray(pr, dtype=float)
    s3 = confining_pressure / 1e3
    levels = np.array(sorted(AYERS_SAND))
    if not levels[0] <= s3 <= levels[-1]:
        raise ValueError(f"confining pressure {s3} kPa outside {levels[0]}-{levels[-1]} kPa")
    qf_levels = np.stack([AYERS_SAND[k][0] + AYERS_SAND[k][1] * pr for k in levels])
    qf = np.array([np.interp(s3, levels, col) for col in qf_levels.reshape(levels.size, -1).T]).reshape(pr.shape)
    phi = np.arcsin(qf / (qf + 2.0 * s3))
    return phi, (pr >= AYERS_PR_RANGE[0]) & (pr <= AYERS_PR_RANGE[1])
