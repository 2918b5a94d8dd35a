"""What a run regularised, and how much that is estimated to move its result.

Three devices can stand between a scene and the rate-independent answer; each is a scene key
with a default the solver chooses:

* ``regularising_cohesion``: a small cohesion put in place of c = 0 (default 1 kPa);
* ``relaxation_length``: Duvaut-Lions viscoplasticity over a length of the wheel's path (default
  off; a failed run on a non-associated soil suggests one);
* ``relaxation_fallback``: the same over a short stretch of sinkage after Newton failed on the
  unregularised soil, then the rate-independent push goes on (default 0.01 mm);
* ``travel_relaxation_fallback``: the same for a roll, which starts over relaxed to its end
  (default 0.5 mm);
* ``plateau_tolerance``: Newton plateaus below this share of the internal-force norm accepted as
  converged (default 1e-4).

:func:`regularisation_summary` lists the ones a run applied, for ``summary.json``
(``model.regularisation``), each with an estimate of its effect from the measurements in the
docs and the key that tightens it.  The estimates are ranges measured on particular soils, not
bounds.  The measurements: docs/benchmarks.md, "c = 0 soil" and "Relaxation length in rolling";
docs/limitations.md, "Purely frictional soil (c = 0)" and "Non-associated flow: Newton stalls".
"""
from __future__ import annotations

import math

__all__ = ["regularisation_summary", "cohesion_bias", "relaxation_bias", "COHESION_EXPONENT"]

#: c_reg = 1 kPa against c = 0 exactly, phi = 40 deg (35 deg for pointwise gives the same range),
#: Q_V at s/d = 0.02 / 0.05 / 0.1 on the fast wheel, both strains: the range of the rise (%)
#: (measured: see docs/benchmarks.md, "c = 0 soil")
COHESION_BIAS_1KPA = (39.0, 97.0)
#: the pointwise bias grows as c_reg**COHESION_EXPONENT over c_reg = 0.5-2 kPa (measured: see
#: docs/benchmarks.md, "c = 0 soil")
COHESION_EXPONENT = 0.71
#: the c_reg range the cohesion bias was measured over (Pa)
COHESION_MEASURED = (500.0, 2000.0)
#: rolling: the bias of a relaxation length is first order, in % per mm (clay, Q_V of a held
#: sinkage; the case-5 soil's constant-load sinkage moves alike, dense sand less; measured: see
#: docs/benchmarks.md, "Relaxation length in rolling")
RELAXATION_ROLLING_PER_MM = 3.0
#: rolling on a c = 0 sand (phi = 40 deg, psi = 0, mu = 0.8, fast, pointwise, continuous protocol):
#: length (mm) -> (low, high) bias of Q_V at s/d = 0.01 / 0.02 / 0.03 (%) against the length-0
#: extrapolations (Richardson and Aitken) of 0.25 / 0.5 / 1 mm: not first order, and large
RELAXATION_ROLLING_C0 = ((0.25, (26.0, 98.0)), (0.5, (50.0, 153.0)), (1.0, (88.0, 238.0)))
#: that sand's extrapolated Q_V grows about as s**RELAXATION_ROLLING_C0_EXPONENT from s/d = 0.01 to
#: 0.03 (see docs/limitations.md, "Purely frictional soil (c = 0)"): a constant load then finds the
#: sinkage (1 + bias)**(-1 / RELAXATION_ROLLING_C0_EXPONENT) times the unrelaxed one
RELAXATION_ROLLING_C0_EXPONENT = 0.5
#: indentation of a c = 0 sand (phi = 40 deg, pointwise): length (mm) -> bias of Q_V at s/d = 0.1 (%)
#: against the rate-independent value (measured: see docs/benchmarks.md, "c = 0 soil")
RELAXATION_INDENTATION = ((1 / 512, 15.0), (1 / 256, 25.0), (1 / 128, 29.0), (1 / 64, 43.0), (1 / 32, 63.0),
                          (1 / 16, 96.0), (1 / 8, 145.0), (1 / 4, 218.0), (1.0, 520.0))

#: fallback relaxation (default 0.01 mm over 0.005 d of sinkage after a failure), measured on the
#: plane-strain extremes matrix (`python -m benchmarks extremes matrix`, fast preset), its length halved:
#: the change of Q_V at s/d = 0.1 on the cells it relaxed, bar one stiff, nearly incompressible
#: steep cone (measured: see docs/benchmarks.md, "Extremes matrix")
FALLBACK_BIAS = (-15.0, 15.0)
FALLBACK_BASIS = ("Q_V at s/d = 0.1 with the length halved: within 1.6 % on 24 and 15 % on 29 of 30 plane-strain "
                  "extremes cells it relaxed; 62 % on one stiff nearly incompressible steep cone")
#: the fallback lengths measured (m)
FALLBACK_MEASURED = (5e-6, 2e-5)


#: travel fallback (default 0.5 mm; the failed roll starts over relaxed to its end): its effect is
#: that of relaxing the whole roll by the same length (:func:`relaxation_bias`); measured on the
#: dense sand of layered case 13 (see docs/limitations.md, "Non-associated flow: Newton stalls")
TRAVEL_FALLBACK_BASIS = ("the bias of relaxing the whole roll by this length (first order, about 3 % per mm); "
                         "dense sand, Q_V with 0.5 mm halved: -0.30 %")
#: the travel fallback lengths measured (m)
TRAVEL_FALLBACK_MEASURED = (2.5e-4, 1e-3)


def cohesion_bias(c_reg: float) -> tuple[tuple[float, float], bool]:
    """Estimated rise of Q_V (%, low and high) from a regularising cohesion ``c_reg`` (Pa) in place
    of c = 0, and whether ``c_reg`` lies in the measured range (outside it the power law is
    extrapolated)."""
    scale = (c_reg / 1e3) ** COHESION_EXPONENT
    lo, hi = COHESION_BIAS_1KPA
    return (lo * scale, hi * scale), COHESION_MEASURED[0] <= c_reg <= COHESION_MEASURED[1]


def relaxation_bias(length: float, protocol: str, cohesionless: bool = False) -> tuple[tuple[float, float], bool]:
    """Estimated effect (%, low and high, as a magnitude) of a Duvaut-Lions relaxation ``length``
    (m) on the run's result, and whether ``length`` lies in the measured range.  Rolling: first
    order, from 0 to :data:`RELAXATION_ROLLING_PER_MM` per mm; on a soil with a c = 0 layer
    (``cohesionless``) interpolated in log(length) in :data:`RELAXATION_ROLLING_C0`.  Indentation:
    interpolated in log(length) in :data:`RELAXATION_INDENTATION` (c = 0 sand; soils with cohesion
    were not measured)."""
    mm = 1e3 * length
    if protocol != "indentation" and not cohesionless:
        return (0.0, RELAXATION_ROLLING_PER_MM * mm), 0.5 <= mm <= 4.0
    if protocol != "indentation":
        lo, inside = _interpolated([(a, b[0]) for a, b in RELAXATION_ROLLING_C0], mm)
        return (lo, _interpolated([(a, b[1]) for a, b in RELAXATION_ROLLING_C0], mm)[0]), inside
    hi, inside = _interpolated(RELAXATION_INDENTATION, mm)
    return (0.0, hi), inside


def _interpolated(table, mm: float) -> tuple[float, bool]:
    """The value of ``table`` ((length in mm, value), ascending) at ``mm``, linear in log(length)
    and held at the ends, and whether ``mm`` lies inside the table."""
    lengths = [math.log(a) for a, _ in table]
    values = [b for _, b in table]
    x = math.log(mm)
    inside = lengths[0] <= x <= lengths[-1]
    x = min(max(x, lengths[0]), lengths[-1])
    k = next(i for i in range(1, len(lengths)) if x <= lengths[i])
    w = (x - lengths[k - 1]) / (lengths[k] - lengths[k - 1])
    return values[k - 1] + w * (values[k] - values[k - 1]), inside


def _rolling_basis(cohesionless: bool) -> str:
    """Where the rolling estimate of a relaxation length comes from."""
    if cohesionless:
        return ("c = 0 sand, phi = 40 deg, continuous rolling: Q_V at s/d = 0.01-0.03 against the length-0 "
                "extrapolations of 0.25 / 0.5 / 1 mm (not first order)")
    return "first order in the length: clay and a c-phi soil about 3 % per mm, dense sand less"


def _signed(lo: float, hi: float, quantity: str, cohesionless: bool = False) -> list[float]:
    """A relaxation's effect range (%, magnitudes) with its sign: Q_V up, constant-load sinkage down
    (on c = 0 soil the Q_V bias is turned into a sinkage through the force-sinkage exponent
    :data:`RELAXATION_ROLLING_C0_EXPONENT`; elsewhere the measured ranges are first order)."""
    if quantity == "sinkage" and cohesionless:
        lo, hi = (100 * (1 - (1 + b / 100) ** (-1 / RELAXATION_ROLLING_C0_EXPONENT)) for b in (lo, hi))
    sign = -1 if quantity == "sinkage" else 1
    return sorted([round(sign * lo, 1) + 0.0, round(sign * hi, 1) + 0.0])


def regularisation_summary(protocol: str, *, regularised: dict, relaxation_length: float,
                           plateau_tolerance: float, plateau_share: float, relaxation_fallback: float = 0.0,
                           relaxed_spans=(), travel_relaxation_fallback: float = 0.0,
                           relaxed_travel=(), cohesionless: bool = False) -> list[dict]:
    """The ``model.regularisation`` entries of a run (empty when it solved the scene as stated).

    protocol : loading protocol; regularised : ``{"soil.layers[i]": c_reg (Pa)}``;
    relaxation_length : m; plateau_tolerance : accepted plateau / internal-force norm;
    plateau_share : largest residual force an accepted plateau left, over that step's Q_V;
    relaxation_fallback : m; relaxed_spans : ``(from, to)`` sinkage (m) of each stretch it relaxed;
    travel_relaxation_fallback : m; relaxed_travel : ``(from, to)`` travel (m) of each stretch it relaxed;
    cohesionless : a soil layer is solved with c = 0 exactly (a relaxation biases a roll far more)
    """
    quantity = "sinkage" if protocol == "rolling-constant-load" else "QV"
    entries = []
    for layer, c_reg in sorted(regularised.items()):
        (lo, hi), measured = cohesion_bias(c_reg)
        entries.append({
            "kind": "regularising_cohesion", "key": "model.regularising_cohesion", "value": c_reg, "unit": "Pa",
            "applies_to": layer,
            "effect": {"quantity": "QV", "percent": [round(lo, 1), round(hi, 1)], "measured_range": measured,
                       "basis": "Q_V raised: c = 0 against c_reg, phi = 35-40 deg, s/d = 0.02-0.1, indentation"},
            "tighten": "lower model.regularising_cohesion; 0 keeps c = 0 exactly (slower)"})
    if relaxation_length > 0:
        (lo, hi), measured = relaxation_bias(relaxation_length, protocol, cohesionless)
        entries.append({
            "kind": "duvaut_lions", "key": "model.relaxation_length", "value": relaxation_length, "unit": "m",
            "applies_to": "soil",
            "effect": {"quantity": quantity, "percent": _signed(lo, hi, quantity, cohesionless),
                       "measured_range": measured,
                       "basis": _rolling_basis(cohesionless) if protocol != "indentation" else
                       "c = 0 sand, phi = 40 deg, Q_V at s/d = 0.1; soils with cohesion not measured"},
            "tighten": "halve model.relaxation_length: the result should move by less than the accuracy needed"})
    if relaxed_spans:
        lo, hi = FALLBACK_BIAS
        entries.append({
            "kind": "duvaut_lions_fallback", "key": "model.relaxation_fallback", "value": relaxation_fallback,
            "unit": "m", "applies_to": "soil, over " + ", ".join(f"s = {a:.4g}-{b:.4g} m" for a, b in relaxed_spans),
            "effect": {"quantity": "QV", "percent": [lo, hi],
                       "measured_range": FALLBACK_MEASURED[0] <= relaxation_fallback <= FALLBACK_MEASURED[1],
                       "basis": FALLBACK_BASIS},
            "tighten": "halve model.relaxation_fallback and compare; 0 stops the run at the failure instead"})
    if relaxed_travel:
        (lo, hi), measured = relaxation_bias(travel_relaxation_fallback, protocol, cohesionless)
        entries.append({
            "kind": "duvaut_lions_travel_fallback", "key": "model.travel_relaxation_fallback",
            "value": travel_relaxation_fallback, "unit": "m",
            "applies_to": "soil, over " + ", ".join(f"travel = {a:.4g}-{b:.4g} m" for a, b in relaxed_travel),
            "effect": {"quantity": quantity, "percent": _signed(lo, hi, quantity, cohesionless),
                       "measured_range": measured if cohesionless else TRAVEL_FALLBACK_MEASURED[0]
                       <= travel_relaxation_fallback <= TRAVEL_FALLBACK_MEASURED[1],
                       "basis": _rolling_basis(True) if cohesionless else TRAVEL_FALLBACK_BASIS},
            "tighten": "halve model.travel_relaxation_fallback and compare; 0 stops the run at the failure instead"})
    if plateau_share > 0:
        entries.append({
            "kind": "newton_plateaus", "key": "model.plateau_tolerance", "value": plateau_tolerance, "unit": "",
            "applies_to": "Newton",
            "effect": {"quantity": "QV", "percent": [round(-100 * plateau_share, 3), round(100 * plateau_share, 3)],
                       "measured_range": True,
                       "basis": "largest out-of-balance force an accepted plateau left, over that step's Q_V"},
            "tighten": "lower model.plateau_tolerance and compare (0 cuts the step instead): on "
                       "non-associated soil the path can move by more than the residual"})
    return entries
