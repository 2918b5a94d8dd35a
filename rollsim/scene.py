"""Scene files (TOML; format: docs/scene.md): loading and validation, SI inside.

``load_scene(path) -> Scene``. Any bad value raises ``InputError`` whose field is
the dotted key (``soil.layers[1].nu``); unknown keys are errors too, so a typo
never silently falls back to a default. Angles are stored in radians.
"""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

from rollsim.files import read_toml
from rollsim.log import get_logger
from rollsim.presets import Preset, resolve_preset
from rollsim.solver.options import (ACCURACIES, CELL_TYPES, DEFAULT_ACCURACY, DEFAULT_KINEMATICS,
                                    DEFAULT_ROLLING_METHOD, DEFAULT_LINEAR_SOLVER, DEFAULT_MATCH,
                                    DEFAULT_REGULARISING_COHESION, DEFAULT_RELAXATION_FALLBACK,
                                    DEFAULT_RELAXATION_LENGTH, DEFAULT_TRAVEL_RELAXATION_FALLBACK,
                                    DEFAULT_VOLUMETRIC_STRAIN, KINEMATICS, LINEAR_SOLVERS, MATCHES,
                                    PLATEAU_RTOL, PROTOCOLS, ROLLING_METHODS, VOLUMETRIC_STRAINS)
from rollsim.units import (ANGLE, DIMENSIONLESS, FORCE, LENGTH, PRESSURE, UNIT_WEIGHT, InputError, Kind,
                           to_si)

log = get_logger("scene")

WHEEL_TYPES = ("rigid", "pneumatic")
WHEEL_SHAPES = ("cylinder", "torus")
SOIL_MODELS = ("von-mises", "drucker-prager", "mohr-coulomb")
TREAD_THICKNESS_RATIO = 0.046  # t_tread / d of the report's tire
#: the carcass's Young's modulus (Pa) that makes the Mn/DOT-size tire at 650 kPa deflect 90 mm on
#: rigid ground under 133.5 kN (docs/tire.md: the target, its band and the calibration)
DEFAULT_E_CARCASS = 78e6


@dataclass(frozen=True)
class WheelSpec:
    """The wheel: dimensions (m), Coulomb friction, and for a tire its hub and carcass."""

    type: str
    shape: str
    diameter: float
    width: float
    fillet: float
    friction: float
    hub_diameter: float | None = None
    inflation: float | None = None  # Pa
    E_carcass: float | None = None  # Pa
    nu_carcass: float | None = None
    t_tread: float | None = None  # m


@dataclass(frozen=True)
class LayerSpec:
    """One soil layer. Strength as given: (phi_dp, c_dp) or Mohr-Coulomb (c, phi) + match."""

    model: str
    E: float
    nu: float
    thickness: float | None  # m; None for the last layer
    phi_dp: float | None = None  # rad
    c_dp: float | None = None  # Pa
    c: float | None = None  # Pa
    phi: float | None = None  # rad
    match: str = "compression"
    dilation: float = 0.0  # rad


@dataclass(frozen=True)
class SoilSpec:
    gamma: float  # N/m^3
    layers: tuple[LayerSpec, ...]


@dataclass(frozen=True)
class LoadingSpec:
    protocol: str
    max_sinkage: float | None = None  # m
    load: float | None = None  # N
    travel: float | None = None  # m; not needed by steady rolling
    passes: int | None = None  # steady rolling-constant-load: passes over the same soil; None: one


@dataclass(frozen=True)
class ModelSpec:
    """``[model]``: the solver options (choices and defaults: ``rollsim.solver.options``)."""

    accuracy: str = DEFAULT_ACCURACY
    refinement: float | None = None   # elements per wheel diameter under the wheel; None: the preset's
    cell_type: str | None = None   # a rigid wheel's rolling block: tetrahedra or hexahedra; None: n/a
    elements_across_wheel: float | None = None   # hexahedra: across the wheel's width; None: no finer across
    elements_along_path: float | None = None   # hexahedra: per d along the path in the strip; None: no finer along
    kinematics: str = DEFAULT_KINEMATICS
    linear_solver: str = DEFAULT_LINEAR_SOLVER
    volumetric_strain: str = DEFAULT_VOLUMETRIC_STRAIN   # parse_scene: the preset's for the protocol
    relaxation_length: float = DEFAULT_RELAXATION_LENGTH   # m of the wheel's path; > 0: Duvaut-Lions
    relaxation_fallback: float = DEFAULT_RELAXATION_FALLBACK   # m; a failed vertical move relaxed; 0: off
    travel_relaxation_fallback: float = DEFAULT_TRAVEL_RELAXATION_FALLBACK   # m; a failed roll restarts relaxed
    regularising_cohesion: float = DEFAULT_REGULARISING_COHESION   # Pa in place of c = 0; 0: c stays 0
    plateau_tolerance: float = PLATEAU_RTOL   # Newton plateaus accepted below this x |F_internal|; 0: never
    rolling: str = DEFAULT_ROLLING_METHOD   # a rigid wheel's rolling: "transient" or "steady"

    @property
    def preset(self) -> Preset:
        """What ``accuracy`` sets, with ``refinement`` in place of its element sizes
        (:func:`rollsim.presets.resolve_preset`)."""
        return resolve_preset(self.accuracy, self.refinement)

    @property
    def elements_per_d(self) -> float:
        """Elements per wheel diameter in the refined zone (along the path on a hexahedral rolling
        block; at the contact of a steady window): ``refinement`` if given, else the ``accuracy``
        preset's."""
        preset = self.preset
        if self.rolling == "steady":
            return preset.steady_elements_per_d
        if self.cell_type == "hexahedra":
            return preset.hexahedra[0]
        return preset.elements_per_d

    @property
    def mesh_name(self) -> str:
        """The mesh in words: the preset, or the elements per d that replace it, and the hexahedra's
        elements across the wheel and, where finer, along the path."""
        name = self.accuracy if self.refinement is None else f"{self.refinement:g} elements per d"
        if self.rolling == "steady":
            return f"{name} (steady window, {self.elements_per_d:g} elements per d at the contact)"
        if self.elements_across_wheel is not None:
            per_d = f"{self.elements_per_d:g} per d, " if self.refinement is None else ""
            along = (f", {self.elements_along_path:g} per d along the path"
                     if self.elements_along_path not in (None, self.elements_per_d) else "")
            name += f" (hexahedra, {per_d}{self.elements_across_wheel:g} across the wheel{along})"
        return name


@dataclass(frozen=True)
class Scene:
    wheel: WheelSpec
    soil: SoilSpec
    loading: LoadingSpec
    model: ModelSpec

    def to_dict(self) -> dict:
        """The scene in SI (angles in degrees, as a user reads them) for summaries."""
        def convert(obj, key=""):
            if isinstance(obj, dict):
                return {k: convert(v, k) for k, v in obj.items()}
            if isinstance(obj, (list, tuple)):
                return [convert(v) for v in obj]
            if isinstance(obj, float) and key in ANGLE_KEYS:
                return math.degrees(obj)
            return obj
        return convert(dataclasses.asdict(self))


ANGLE_KEYS = {"phi_dp", "phi", "dilation"}

#: every key of each table (the validator reads those that apply to a case; tests/test_docs.py
#: checks this list against the validator and the docs)
TABLE_KEYS = {
    "wheel": ("type", "shape", "diameter", "width", "fillet", "friction", "hub_diameter", "inflation",
              "E_carcass", "nu_carcass", "t_tread"),
    "soil.layers[]": ("model", "E", "nu", "thickness", "phi_dp", "c_dp", "c", "phi", "match", "dilation"),
    "loading": ("protocol", "max_sinkage", "load", "travel", "passes"),
}

#: plausibility of a scene quantity, by key, SI: ``(hard low, hard high, typical low, typical high)``.
#: Outside the hard range a value is refused (it is a typo or a unit slip: E = "40 GPa" for
#: "40 MPa"); outside the typical range it is accepted with a warning.  docs/scene.md lists them.
PLAUSIBLE = {
    "diameter": (0.01, 20.0, 0.1, 3.0), "width": (1e-3, 10.0, 0.02, 1.5), "fillet": (0.0, 5.0, 0.0, 0.5),
    "friction": (0.0, 2.0, 0.0, 1.0), "hub_diameter": (1e-3, 20.0, 0.05, 2.0),
    "inflation": (1e3, 10e6, 50e3, 1.5e6), "E_carcass": (1e3, 1e12, 1e6, 1e10), "t_tread": (1e-4, 5.0, 1e-3, 0.2),
    "gamma": (100.0, 100e3, 12e3, 25e3), "E": (1e3, 1e12, 1e6, 2e9), "thickness": (1e-3, 1000.0, 0.01, 20.0),
    "c": (0.0, 1e9, 0.0, 2e6), "c_dp": (0.0, 2e9, 0.0, 4e6), "max_sinkage": (1e-6, 5.0, 1e-3, 0.5),
    "load": (1.0, 1e8, 100.0, 2e6), "travel": (1e-3, 1000.0, 0.01, 50.0),
    "relaxation_length": (0.0, 10.0, 0.0, 0.01), "relaxation_fallback": (0.0, 10.0, 0.0, 1e-3),
    "travel_relaxation_fallback": (0.0, 10.0, 0.0, 0.01),
    "regularising_cohesion": (0.0, 1e6, 0.0, 10e3),
    "plateau_tolerance": (0.0, 0.1, 0.0, 0.01), "refinement": (2.0, 200.0, 6.0, 50.0),
    "elements_across_wheel": (1.0, 200.0, 4.0, 32.0), "elements_along_path": (2.0, 400.0, 6.0, 48.0),
}


def _check_plausible(key: str, name: str, value: float, kind: Kind, notes: list) -> None:
    """Refuse ``value`` outside the hard range of :data:`PLAUSIBLE`; outside the typical one, add a
    warning to ``notes`` (logged once the whole scene is valid)."""
    lo, hi, typical_lo, typical_hi = PLAUSIBLE[name]
    unit = f" {kind.si_unit}".replace("**", "^").rstrip()
    if not lo <= value <= hi:
        raise InputError(key, f"{value:g}{unit} is outside the plausible range {lo:g} to {hi:g}{unit} "
                         "(a unit slip?)")
    if not typical_lo <= value <= typical_hi:
        notes.append(f"{key} = {value:g}{unit} is outside the typical range {typical_lo:g} to {typical_hi:g}{unit}")


class _Table:
    """A TOML table being read: typed getters that name the dotted key, and leftovers are errors."""

    def __init__(self, data, path: str, notes: list | None = None):
        if not isinstance(data, dict):
            raise InputError(path, "must be a table")
        self.data, self.path, self.used = data, path, set()
        self.notes = [] if notes is None else notes     # warnings, shared by a scene's tables

    def key(self, name):
        return f"{self.path}.{name}" if self.path else name

    def has(self, name):
        return name in self.data

    def raw(self, name, default=None):
        self.used.add(name)
        return self.data.get(name, default)

    def quantity(self, name, kind: Kind, *, default=None, required=False, positive=False, minimum=None):
        if name not in self.data:
            if required:
                raise InputError(self.key(name), "is required")
            return default
        value = to_si(self.raw(name), kind, self.key(name))
        if kind is ANGLE:
            value = math.radians(value)
        if positive and not value > 0:
            raise InputError(self.key(name), "must be positive")
        if minimum is not None and value < minimum:
            raise InputError(self.key(name), f"must be at least {minimum}")
        if name in PLAUSIBLE:
            _check_plausible(self.key(name), name, value, kind, self.notes)
        return value

    def choice(self, name, allowed, default=None):
        if name not in self.data and default is not None:
            return default
        value = self.raw(name)
        if value not in allowed:
            raise InputError(self.key(name), f"must be one of {', '.join(allowed)}, got {value!r}")
        return value

    def done(self, context: str = ""):
        """Refuse the keys left unread: a key of this table that the case does not use is named
        as not applying (``context`` says to what), any other as unknown."""
        extra = sorted(set(self.data) - self.used)
        if extra:
            name = extra[0]
            known = TABLE_KEYS.get(re.sub(r"\[\d+\]$", "[]", self.path), ())
            if name in known and context:
                raise InputError(self.key(name), f"does not apply to {context}")
            raise InputError(self.key(name), "unknown key")


def _wheel(t: _Table) -> WheelSpec:
    kind = t.choice("type", WHEEL_TYPES, default="rigid")
    shape = t.choice("shape", WHEEL_SHAPES, default="cylinder")
    d = t.quantity("diameter", LENGTH, required=True, positive=True)
    b = t.quantity("width", LENGTH, required=True, positive=True)
    fillet = t.quantity("fillet", LENGTH, default=b / 12, minimum=0.0)
    if fillet >= b / 2:
        raise InputError(t.key("fillet"), f"must be less than half the width ({b / 2:g} m)")
    friction = t.quantity("friction", DIMENSIONLESS, default=0.8, minimum=0.0)
    tire = {}
    if kind == "pneumatic":
        if t.has("shape"):
            raise InputError(t.key("shape"), "applies to rigid wheels only")
        tire = dict(hub_diameter=t.quantity("hub_diameter", LENGTH, required=True, positive=True),
                    inflation=t.quantity("inflation", PRESSURE, required=True, positive=True),
                    E_carcass=t.quantity("E_carcass", PRESSURE, default=DEFAULT_E_CARCASS, positive=True),
                    nu_carcass=t.quantity("nu_carcass", DIMENSIONLESS, default=0.45),
                    t_tread=t.quantity("t_tread", LENGTH, default=TREAD_THICKNESS_RATIO * d, positive=True))
        if not tire["hub_diameter"] < d - 2 * tire["t_tread"]:
            raise InputError(t.key("hub_diameter"), "must be smaller than the tire's inner diameter")
        if not -1 < tire["nu_carcass"] < 0.5:
            raise InputError(t.key("nu_carcass"), "must be in (-1, 0.5)")
    t.done(f"a {kind} wheel")
    return WheelSpec(kind, shape, d, b, fillet, friction, **tire)


def _layer(t: _Table, last: bool) -> LayerSpec:
    model = t.choice("model", SOIL_MODELS)
    E = t.quantity("E", PRESSURE, required=True, positive=True)
    nu = t.quantity("nu", DIMENSIONLESS, required=True)
    if not -1 < nu < 0.5:
        raise InputError(t.key("nu"), "must be in (-1, 0.5)")
    if last and t.has("thickness"):
        raise InputError(t.key("thickness"), "the last layer fills the rest of the block: omit its thickness")
    thickness = None if last else t.quantity("thickness", LENGTH, required=True, positive=True)
    dp_given = t.has("phi_dp") or t.has("c_dp")
    mc_given = t.has("c") or t.has("phi")
    if dp_given and mc_given:
        raise InputError(t.key("c" if t.has("c") else "phi"),
                         "give Drucker-Prager (phi_dp, c_dp) or Mohr-Coulomb (c, phi), not both")
    strength: dict = {}
    if model == "von-mises":
        if t.has("phi_dp") or t.has("phi"):
            raise InputError(t.key("phi_dp" if t.has("phi_dp") else "phi"), "von Mises soil has no friction angle")
        if not dp_given and not mc_given:
            raise InputError(t.key("c_dp"), "give the yield stress c_dp or the cohesion c")
    elif model == "mohr-coulomb" and dp_given:
        raise InputError(t.key("phi_dp" if t.has("phi_dp") else "c_dp"), "mohr-coulomb takes c and phi")
    if dp_given:
        strength["c_dp"] = t.quantity("c_dp", PRESSURE, required=True, minimum=0.0)
        strength["phi_dp"] = t.quantity("phi_dp", ANGLE, default=0.0 if model == "von-mises" else None,
                                        required=model != "von-mises", minimum=0.0)
        if strength["phi_dp"] >= math.radians(71.5):  # tan(phi_dp) = 3: the cone degenerates
            raise InputError(t.key("phi_dp"), "must be below 71.5 deg")
    else:
        strength["c"] = t.quantity("c", PRESSURE, required=True, minimum=0.0)
        strength["phi"] = t.quantity("phi", ANGLE, default=0.0 if model == "von-mises" else None,
                                     required=model != "von-mises", minimum=0.0)
        if strength["phi"] >= math.radians(90):
            raise InputError(t.key("phi"), "must be below 90 deg")
        strength["match"] = t.choice("match", MATCHES, default=DEFAULT_MATCH)
    friction_angle = strength.get("phi_dp", strength.get("phi", 0.0))
    if (strength.get("c_dp", strength.get("c")) == 0) and friction_angle == 0:
        raise InputError(t.key("c_dp" if dp_given else "c"), "a soil without cohesion needs a friction angle")
    dilation = t.quantity("dilation", ANGLE, default=0.0, minimum=0.0)
    if dilation > friction_angle:
        raise InputError(t.key("dilation"), "must not exceed the friction angle")
    t.done(f"a {model} layer given by {'phi_dp/c_dp' if dp_given else 'c/phi'}")
    return LayerSpec(model=model, E=E, nu=nu, thickness=thickness, dilation=dilation, **strength)


def _soil(t: _Table) -> SoilSpec:
    gamma = t.quantity("gamma", UNIT_WEIGHT, required=True, positive=True)
    layers = t.raw("layers")
    if not isinstance(layers, list) or not layers:
        raise InputError(t.key("layers"), "give at least one [[soil.layers]] table")
    specs = tuple(_layer(_Table(layer, f"{t.key('layers')}[{i}]", t.notes), i == len(layers) - 1)
                  for i, layer in enumerate(layers))
    t.done()
    return SoilSpec(gamma, specs)


def _loading(t: _Table, wheel: WheelSpec, steady: bool = False) -> LoadingSpec:
    protocol = t.choice("protocol", PROTOCOLS)
    spec = {"protocol": protocol}
    if protocol in ("indentation", "rolling-continuous"):
        spec["max_sinkage"] = t.quantity("max_sinkage", LENGTH, required=True, positive=True)
        if spec["max_sinkage"] > 0.25 * wheel.diameter:
            raise InputError(t.key("max_sinkage"), f"must be at most d/4 = {wheel.diameter / 4:g} m")
        if protocol == "indentation" and t.has("load"):      # pressed to a wheel load, max_sinkage the limit
            if wheel.type != "pneumatic":
                raise InputError(t.key("load"), "does not apply to protocol indentation with a rigid wheel (pressed "
                                 "to max_sinkage; a pneumatic wheel can be pressed to a load)")
            spec["load"] = t.quantity("load", FORCE, required=True, positive=True)
    else:
        spec["load"] = t.quantity("load", FORCE, required=True, positive=True)
    if protocol.startswith("rolling"):
        spec["travel"] = t.quantity("travel", LENGTH, required=not steady, positive=True)
    if protocol == "rolling-constant-load" and t.has("passes"):
        passes = t.raw("passes")
        if isinstance(passes, bool) or not isinstance(passes, int) or not 1 <= passes <= MAX_PASSES:
            raise InputError(t.key("passes"), f"must be a whole number of passes from 1 to {MAX_PASSES}, got {passes!r}")
        if passes > 1 and not steady:
            raise InputError(t.key("passes"), 'more than one pass needs [model] rolling = "steady"')
        spec["passes"] = passes
    t.done(f"protocol {protocol}")
    return LoadingSpec(**spec)


def _rolling_cells(t: _Table, wheel: WheelSpec, loading: LoadingSpec,
                   preset: Preset) -> tuple[str | None, float | None, float | None]:
    """``[model] cell_type``, ``elements_across_wheel`` and ``elements_along_path``: (cell type,
    elements across the wheel's width, elements per d along the path), None where they do not
    apply.  Hexahedra apply to rolling a rigid wheel; the cell type and the counts default to the
    ``preset``'s (:class:`rollsim.presets.Preset`: ``rolling_cell_type``, ``hexahedra``)."""
    keys = ("cell_type", "elements_across_wheel", "elements_along_path")
    if wheel.type != "rigid" or not loading.protocol.startswith("rolling"):
        for key in keys:
            if t.has(key):
                raise InputError(t.key(key), "applies to rolling a rigid wheel (indentation blocks are tetrahedral, "
                                 "a pneumatic wheel's hexahedral)")
        return None, None, None
    cell_type = t.choice("cell_type", CELL_TYPES, default=preset.rolling_cell_type)
    across = t.quantity("elements_across_wheel", DIMENSIONLESS, default=None, positive=True)
    along = t.quantity("elements_along_path", DIMENSIONLESS, default=None, positive=True)
    if cell_type != "hexahedra":
        for key, value in zip(keys[1:], (across, along)):
            if value is not None:
                raise InputError(t.key(key), 'needs cell_type = "hexahedra" (tetrahedral element sizes are isotropic)')
        return cell_type, None, None
    per_d, default_across, default_along = preset.hexahedra
    if along is not None and along < per_d:
        raise InputError(t.key("elements_along_path"), f"must be at least the elements per d ({per_d:g}): the "
                         "strip is refined along the path, never coarsened")
    return cell_type, default_across if across is None else across, default_along if along is None else along


#: the most passes of ``loading.passes``
MAX_PASSES = 50

#: the [model] keys of the transient rolling block and solver that a steady window does not use
TRANSIENT_ONLY = ("cell_type", "elements_across_wheel", "elements_along_path", "relaxation_fallback",
                  "travel_relaxation_fallback", "plateau_tolerance", "linear_solver")


def _rolling_method(t: _Table, wheel: WheelSpec, soil: SoilSpec, loading: LoadingSpec) -> str:
    """``[model] rolling``: how a rigid wheel rolls; "steady" only where a steady window models the
    scene (a rigid cylinder on uniform or horizontally layered soil, small strain)."""
    if not loading.protocol.startswith("rolling"):
        if t.has("rolling"):
            raise InputError(t.key("rolling"), "applies to the rolling protocols")
        return DEFAULT_ROLLING_METHOD
    method = t.choice("rolling", ROLLING_METHODS, default=DEFAULT_ROLLING_METHOD)
    if method != "steady":
        return method
    if wheel.type != "rigid":
        raise InputError(t.key("rolling"), '"steady" rolls a rigid wheel; the pneumatic tire rolls "transient"')
    if wheel.shape != "cylinder":
        raise InputError(t.key("rolling"), '"steady" rolls a cylinder (wheel.shape = "cylinder")')
    if t.data.get("kinematics", DEFAULT_KINEMATICS) != DEFAULT_KINEMATICS:
        raise InputError(t.key("kinematics"), f'steady rolling is {DEFAULT_KINEMATICS} (the streamlines are straight)')
    for key in TRANSIENT_ONLY:
        if t.has(key):
            raise InputError(t.key(key), "does not apply to steady rolling (its window is sized from the wheel and "
                             "the preset: docs/scene.md)")
    return method


def parse_scene(data: dict) -> Scene:
    """A scene from parsed TOML data (a dict); raises ``InputError`` naming the key."""
    top = _Table(data, "")
    sections = {}
    for name in ("wheel", "soil", "loading"):
        if not top.has(name):
            raise InputError(name, "section is required")
        sections[name] = _Table(top.raw(name), name, top.notes)
    wheel = _wheel(sections["wheel"])
    soil = _soil(sections["soil"])
    model_table = _Table(top.raw("model", {}), "model", top.notes)
    loading = _loading(sections["loading"], wheel, steady=model_table.data.get("rolling") == "steady")
    rolling = _rolling_method(model_table, wheel, soil, loading)
    accuracy = model_table.choice("accuracy", ACCURACIES, default=DEFAULT_ACCURACY)
    refinement = model_table.quantity("refinement", DIMENSIONLESS, default=None)
    preset = resolve_preset(accuracy, refinement)
    strain = preset.volumetric_strain(loading.protocol, wheel.type)
    cell_type, across, along = (None, None, None) if rolling == "steady" else \
        _rolling_cells(model_table, wheel, loading, preset)
    model = ModelSpec(accuracy=accuracy, refinement=refinement, cell_type=cell_type, elements_across_wheel=across,
                      elements_along_path=along,
                      kinematics=model_table.choice("kinematics", KINEMATICS, default=DEFAULT_KINEMATICS),
                      linear_solver=model_table.choice("linear_solver", LINEAR_SOLVERS, default=preset.linear_solver),
                      volumetric_strain=model_table.choice("volumetric_strain", VOLUMETRIC_STRAINS, default=strain),
                      relaxation_length=model_table.quantity("relaxation_length", LENGTH,
                                                             default=DEFAULT_RELAXATION_LENGTH, minimum=0.0),
                      relaxation_fallback=model_table.quantity("relaxation_fallback", LENGTH,
                                                               default=DEFAULT_RELAXATION_FALLBACK, minimum=0.0),
                      travel_relaxation_fallback=model_table.quantity(
                          "travel_relaxation_fallback", LENGTH, default=DEFAULT_TRAVEL_RELAXATION_FALLBACK, minimum=0.0),
                      regularising_cohesion=model_table.quantity("regularising_cohesion", PRESSURE,
                                                                 default=DEFAULT_REGULARISING_COHESION, minimum=0.0),
                      plateau_tolerance=model_table.quantity("plateau_tolerance", DIMENSIONLESS,
                                                             default=PLATEAU_RTOL, minimum=0.0),
                      rolling=rolling)
    if model.regularising_cohesion == 0:
        for i, layer in enumerate(soil.layers):
            if layer.model == "mohr-coulomb" and layer.c == 0:
                raise InputError("model.regularising_cohesion", f"0 needs c > 0 in soil.layers[{i}] (mohr-coulomb: "
                                 "the smoothed surface's rounded tip needs a cohesion); use drucker-prager for c = 0")
    model_table.done()
    top.done()
    for note in top.notes:
        log.warning(note)
    return Scene(wheel, soil, loading, model)


def load_scene(path) -> Scene:
    """Read and validate a scene file."""
    return parse_scene(read_toml(path, str(path)))
