"""Scenario files: YAML scenes with units, validated into SI at load time.

Every field is documented in README.md ("Scenario format").  A bad file raises
:class:`autobal.errors.ScenarioError` with one line naming the file, the field and the
expected unit.
"""

from __future__ import annotations

import hashlib
import importlib
import numbers
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import Field, PrivateAttr, ValidationError, create_model, model_validator

from autobal.errors import ScenarioError
from autobal.paths import SCENARIO_DIR
from autobal.schema import MAX_FORCE_GAP_POINTS, NonNegative, Positive, PressureRatio, Range, Strict
from autobal.text import LIMIT, clean
from autobal.units import (
    AngularSpeed,
    Area,
    Density,
    Force,
    ForceOrZero,
    Length,
    Pressure,
    PressureOrZero,
    Viscosity,
    VolumeFlow,
    clip,
)


def _d(text: str, default=..., **kw):
    """A field with its meaning for the schema reference (units are added by the quantity types)."""
    return Field(default, description=text, **kw)


class Fluid(Strict):
    """The working fluid of the balancing device."""

    density: Density = _d("liquid density, or gas density at normal conditions (rho)")
    viscosity: Viscosity = _d("dynamic viscosity (mu)")
    normal_pressure: Pressure | None = _d("gas only: pressure of the normal conditions of the density, "
                                          "Pavlenko (2014), Eq. (2.128)", None)


class Impeller(Strict):
    """Impeller data for the axial-force ratio b, Pavlenko (2014), Eq. (2.18) and Appendix A."""

    hub_radius: Length = _d("hub radius R0")
    shroud_radius: Length = _d("shroud seal radius R1")
    outer_radius: Length = _d("impeller outer radius R2")
    stages: Annotated[int, Field(ge=1, le=100)] = _d("number of stages, 1 to 100")
    speed: AngularSpeed = _d("rotational speed")


class Operating(Strict):
    """Nominal operating data of the machine; the bases p_B and s_B of the dimensionless groups."""

    nominal_pressure: Pressure = _d("nominal discharge pressure p_n = p_B, the pressure base")
    nominal_thrust: Force = _d("nominal axial thrust T_n; the area base is s_B = T_n / p_n")
    nominal_flow: VolumeFlow | None = _d("nominal flow Q_n of the machine, for Q_e / Q_n", None)
    drain_pressure: PressureOrZero = _d("drain pressure p4 behind the outer seal", 0.0)
    thrust_ratio: Positive | None = _d("b in tau = b psi1, dimensionless; computed from the impeller when "
                                       "omitted", None)
    impeller: Impeller | None = _d("impeller data, to compute thrust_ratio", None)

    @model_validator(mode="after")
    def _b_given(self):
        if self.thrust_ratio is None and self.impeller is None:
            raise ValueError("give thrust_ratio (b) or impeller data to compute it")
        if self.drain_pressure >= self.nominal_pressure:
            raise ValueError(f"drain_pressure: {self.drain_pressure / 1e6:g} MPa is not below the nominal discharge "
                             f"pressure {self.nominal_pressure / 1e6:g} MPa; the device leaks from the discharge to "
                             "the drain (above it the face is pressed shut and nothing is balanced)")
        return self


class InnerSeal(Strict):
    """Laminar annular bushing seal, g1 = pi d h^3 / (12 mu l)."""

    diameter: Length = _d("seal diameter d1")
    length: Length = _d("seal length l1")
    clearance: Length = _d("radial clearance h1")


class OuterSeal(Strict):
    """Square-root-law annular seal, zeta = zeta_local + lambda l / (2h)."""

    diameter: Length = _d("seal diameter d3")
    length: Length = _d("seal length l3")
    clearance: Length = _d("radial clearance h3")
    local_loss: NonNegative = _d("local loss coefficient zeta_local, dimensionless", 1.5)
    friction: Positive = _d("friction factor lambda, dimensionless", 0.06)


class Face(Strict):
    """Face throttle between the disc and the pad; conductance g_TB u^(3/2)."""

    inner_diameter: Length = _d("inner diameter of the face annulus")
    outer_diameter: Length = _d("outer diameter of the face annulus; larger than inner_diameter")
    base_gap: Length = _d("base face gap z_B = h_TB, the gap base")
    friction: Positive = _d("friction factor lambda of the face gap, dimensionless", 0.06)

    @model_validator(mode="after")
    def _annulus(self):
        if self.outer_diameter <= self.inner_diameter:
            raise ValueError("outer_diameter must be larger than inner_diameter")
        return self


class Disc(Strict):
    """The balancing disc: inner seal, face throttle, outer seal and the push-off spring."""

    inner_seal: InnerSeal = _d("laminar inner seal (throttle 1)")
    face: Face = _d("face throttle (throttle T)")
    outer_seal: OuterSeal = _d("square-root-law outer seal (throttle 3)")
    pushoff_force: ForceOrZero = _d("push-off spring force F_pr", 0.0)

    @model_validator(mode="after")
    def _seal_inside_face(self):
        if self.inner_seal.diameter >= self.face.inner_diameter:
            raise ValueError("inner_seal.diameter must be smaller than face.inner_diameter")
        return self


class Tube(Strict):
    """Laminar round tube, g = pi d^4 / (192 mu l) (the source's coefficient)."""

    diameter: Length = _d("bore diameter")
    length: Length = _d("tube length")


class Barrier(Strict):
    """The barrier chamber fed through a supply throttle at a regulated margin above discharge."""

    supply_throttle: Tube = _d("laminar supply throttle e")
    margin_ratio: Annotated[float, Field(gt=0, le=10)] = _d(
        "regulator set-point dpsi = (p_e - p1) / p_B, dimensionless, 0 to 10")


class Valve(Strict):
    """The regulator's valve (an orifice)."""

    seat_diameter: Length = _d("valve seat diameter d_c")
    base_opening: Length = _d("base valve opening x_B, the opening base")
    discharge_coefficient: Annotated[float, Field(gt=0, le=1)] = _d("discharge coefficient, 0 to 1", 0.54)
    max_opening: Length | None = _d("valve travel limit; unlimited when omitted", None)


class Regulator(Strict):
    """Pressure-drop regulator that holds the barrier pressure at a margin above discharge."""

    supply_pressure: Pressure = _d("supply pressure p_in of the regulator")
    inlet_throttle: Tube = _d("laminar inlet throttle")
    valve: Valve = _d("the valve")
    membrane_area: Area = _d("membrane area s_m")


class DeviceParts(Strict):
    """The axial balancing device without its dynamics section (see :func:`device_model`)."""

    medium: Literal["liquid", "gas"] = _d("working medium: liquid (pump) or gas (compressor)")
    fluid: Fluid = _d("fluid properties")
    operating: Operating = _d("nominal operating data and bases")
    disc: Disc = _d("the balancing disc")
    barrier: Barrier = _d("the barrier chamber")
    regulator: Regulator | None = _d("pressure-drop regulator; none: the barrier at a fixed margin", None)

    @model_validator(mode="after")
    def _gas_needs_normal_pressure(self):
        if self.medium == "gas" and self.fluid.normal_pressure is None:
            raise ValueError("fluid.normal_pressure is required for a gas (Pa, e.g. '0.1 MPa')")
        return self


class Statics(Strict):
    """Static calculation: operating point, sweep over discharge pressure, criticals."""

    operating_ratio: PressureRatio = _d("psi1 = p1 / p_B of the reported operating point, 0 to 100", 1.0)
    discharge_ratio: Range = _d("sweep of psi1 = p1 / p_B, Pavlenko (2014), Figs 2.4-2.6")
    force_gap_points: Annotated[int, Field(ge=2, le=MAX_FORCE_GAP_POINTS)] = _d(
        f"points of the force-gap characteristic phi(u), Eq. (2.35), 2 to {MAX_FORCE_GAP_POINTS}", 60)

    @model_validator(mode="after")
    def _ratios(self):
        if self.discharge_ratio.stop > 100:
            raise ValueError("discharge_ratio.stop: at most 100 (p1 / p_B)")
        return self


# The schema of each analysis and optional scene part, as (module, class, description), in the scene's order;
# an analysis also names the part of the scene it needs (a dotted path, checked at load time), or None.
# A schema module is imported, and its pydantic models built, only when a scene names that analysis or part
# (see :func:`model_for`); ``Scenario`` (all of them) is built on first use, for the schema reference.
ANALYSES = {
    "statics": (__name__, "Statics", "static calculation", "device"),
    "frequency": ("autobal.schema_dynamics", "Frequency", "frequency response (AFC/Bode)", "device.dynamics"),
    "stability": ("autobal.schema_dynamics", "Stability", "poles, Hurwitz, stability maps", "device.dynamics"),
    "transient": ("autobal.schema_dynamics", "Transient", "time responses", "device.dynamics"),
    "liquid_balancer": ("autobal.schema_liquid_balancer", "LiquidBalancerAnalysis", "liquid auto-balancer studies",
                        "liquid_balancer"),
    "estimation": ("autobal.schema_estimation", "Estimation", "parameter fits to measured characteristics", None),
    "montecarlo": ("autobal.schema_reliability", "MonteCarlo", "Monte Carlo of the statics (and AFC)", "device"),
    "reliability": ("autobal.schema_reliability", "Reliability", "traditional disc wear and time to failure", None),
    "rotor_dynamics": ("autobal.schema_rotor", "RotorDynamics", "Jeffcott rotor studies", "rotor"),
    "spinup": ("autobal.schema_rotor", "Spinup", "optimal spin-up through the critical speed", "rotor"),
    "spinup_robust": ("autobal.schema_rotor", "SpinupRobust", "one spin-up profile for a set of rotors (worst case)",
                      "rotor"),
    "spinup_time_optimal": ("autobal.schema_rotor", "SpinupTimeOptimal",
                            "earliest arrival with the peak bounded, and the front of peak against arrival time",
                            "rotor"),
    "design": ("autobal.schema_design", "Design", "stability-constrained design of the device", "device.dynamics"),
    "ross_spinup": ("autobal.schema_ross", "RossSpinup",
                    "optimal spin-up of a ROSS rotor reduced to its modes (the ross extra)", "ross_rotor"),
}
PARTS = {
    "device": (__name__, "Device", "the axial balancing device (statics, dynamics, Monte Carlo, fits)"),
    "liquid_balancer": ("autobal.schema_liquid_balancer", "LiquidBalancer", "liquid auto-balancer"),
    "rotor": ("autobal.schema_rotor", "Rotor", "Jeffcott rotor with optional liquid layer and drive"),
    "ross_rotor": ("autobal.schema_ross", "RossRotor",
                   "a rotor as ROSS elements or a ROSS example rotor (the ross extra)"),
    "executor": ("autobal.schema_reliability", "Executor", "where sweeps and Monte Carlo run"),
}
DYNAMICS = ("autobal.schema_dynamics", "Dynamics",
            "masses, springs, volumes for the frequency, stability and transient analyses")


def _field(entry: tuple, named: bool):
    """An optional field with its schema when the scene names it, else one that admits only its absence."""
    module, cls, text, *needs = entry
    if needs and needs[0]:
        text = f"{text}; needs {needs[0]}"
    return (getattr(importlib.import_module(module), cls) | None if named else None, _d(text, None))


@cache
def device_model(dynamics: bool = True) -> type[DeviceParts]:
    """The ``Device`` model, with the schema of its ``dynamics`` section or (False) without it.

    Parameters
    ----------
    dynamics : bool
        Build the schema of ``device.dynamics`` (imports autobal.schema_dynamics).

    Returns
    -------
    type
        A pydantic model named ``Device``.
    """
    return create_model("Device", __base__=DeviceParts, __module__=__name__,
                        __doc__="The axial balancing device, Pavlenko (2014), ch. 2.",
                        dynamics=_field(DYNAMICS, dynamics))


@cache
def analyses_model(named: frozenset[str]) -> type[Strict]:
    """The ``Analyses`` model with the schemas of the analyses in ``named``; the others must be absent."""
    return create_model("Analyses", __base__=Strict, __module__=__name__,
                        __doc__="The analyses to run; at least one.",
                        **{k: _field(v, k in named) for k, v in ANALYSES.items()})


# a scene's name names its output folder: a plain file name, never a path
NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$"
PRINTABLE = r"^[^\x00-\x1f\x7f-\x9f]*$"  # one line of text: no control characters (C0, DEL, C1)
PRINTABLE_LINES = r"^[^\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]*$"  # text: tabs and line breaks allowed, no escapes


class BaseScenario(Strict):
    """What every scene model shares: its identity and the check that each analysis has its parts.

    The concrete models (``Scenario``, and the slimmer ones :func:`model_for` builds for one scene)
    add the parts and the analyses.
    """

    name: Annotated[str, Field(pattern=NAME_PATTERN)] = _d(
        "identifier of the scene and of its default output folder out/<name>: letters, digits, _ - . "
        "(no path separators, no '..', at most 100 characters)")
    title: Annotated[str, Field(max_length=500, pattern=PRINTABLE)] = _d(
        "one line of text (no control characters), printed on figures")
    source: Annotated[str, Field(max_length=2000, pattern=PRINTABLE_LINES)] = _d(
        "where the inputs come from: plain text (line breaks allowed, no terminal escapes)", "")
    _origin: dict = PrivateAttr(default_factory=dict)  # file, sha256, overrides (set by load)

    @model_validator(mode="after")
    def _parts_for_analyses(self):
        if ".." in self.name:
            raise ValueError("name: must not contain '..' (a plain identifier: letters, digits, _ - .)")
        if not any(v is not None for _, v in self.analyses):
            raise ValueError(f"analyses: the scene names no analysis (one or more of "
                             f"{', '.join(ANALYSES)})")
        for analysis, (*_, path) in ANALYSES.items():
            if path is None or getattr(self.analyses, analysis) is None:
                continue
            node = self
            for part in path.split("."):
                node = getattr(node, part, None)
            if node is None:
                raise ValueError(f"analyses.{analysis} needs a {path} section")
        return self


@cache
def scenario_model(parts: frozenset[str], analyses: frozenset[str], dynamics: bool) -> type[BaseScenario]:
    """A ``Scenario`` model with the schemas of the named scene ``parts``, ``analyses`` and (True) of
    ``device.dynamics``; every part or analysis not named must be absent from the scene.

    Parameters
    ----------
    parts : frozenset of str
        Keys of :data:`PARTS` to validate.
    analyses : frozenset of str
        Keys of :data:`ANALYSES` to validate.
    dynamics : bool
        Validate ``device.dynamics``.

    Returns
    -------
    type
        A pydantic model named ``Scenario``.
    """
    fields = {k: _field(v, k in parts and k != "device") for k, v in PARTS.items()}
    if "device" in parts:  # Device is built here, with or without its dynamics
        fields["device"] = (device_model(dynamics) | None, fields["device"][1])
    fields["analyses"] = (analyses_model(analyses), _d("the analyses to run"))
    return create_model("Scenario", __base__=BaseScenario, __module__=__name__,
                        __doc__="A scene: the machine's parts and the analyses to run on them.", **fields)


def model_for(data) -> type[BaseScenario]:
    """The model that validates a scene mapping exactly as ``Scenario`` does, built from the schemas of
    the parts and analyses it names only (all of them when it is not a mapping of mappings).

    Parameters
    ----------
    data : dict
        A scene as read from YAML.

    Returns
    -------
    type
        A subclass of :class:`BaseScenario`.
    """
    if not isinstance(data, dict) or not isinstance(data.get("analyses"), dict):
        return scenario_model(frozenset(PARTS), frozenset(ANALYSES), True)
    device = data.get("device")
    return scenario_model(frozenset(PARTS).intersection(data), frozenset(ANALYSES).intersection(data["analyses"]),
                          not isinstance(device, dict) or "dynamics" in device)


def __getattr__(name: str):
    """``Scenario``, ``Analyses`` and ``Device`` with every schema, built on first use."""
    if name == "Scenario":
        return scenario_model(frozenset(PARTS), frozenset(ANALYSES), True)
    if name == "Analyses":
        return analyses_model(frozenset(ANALYSES))
    if name == "Device":
        return device_model(True)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


MAX_FILE_BYTES = 1_000_000  # a scene is a page of YAML; anything larger is not a scene
MAX_NODES = 100_000  # values in a scene after YAML aliases are expanded (refuses "billion laughs" files)


def _one_line(err: ValidationError) -> str:
    e = err.errors()[0]
    where = clean(".".join(str(p) for p in e["loc"]) or "(top level)")
    msg = clean(e["msg"].removeprefix("Value error, "), 2 * LIMIT)
    if e["type"] == "extra_forbidden":
        msg = "unknown key"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("name",):
        msg = f"{clean(repr(e['input']))} is not a plain identifier (letters, digits, _ - .; no path separators)"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("title",):
        msg = "control characters (terminal escapes, tabs, line breaks) are not allowed; write one line of text"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("source",):
        msg = "control characters (terminal escapes) are not allowed; write plain text"
    elif e["type"] == "finite_number":
        msg = f"{clean(repr(e['input']))}: must be a finite number"
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    return f"{where}: {msg}{more}"


def resolve(name_or_path: str | Path) -> Path:
    """A scenario path, or the name of a shipped scenario (``scenarios/NAME.yaml``).

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario such as ``"pump_pe600_statics"``.

    Returns
    -------
    Path
    """
    p = Path(name_or_path)
    try:
        if p.is_file():
            return p
        shipped = SCENARIO_DIR / f"{p.stem}.yaml"
        if p.suffix in ("", ".yaml") and shipped.is_file() and p.parent == Path("."):
            return shipped
        if p.is_dir():
            raise ScenarioError(f"{clean(name_or_path)}: is a folder, not a scenario file")
    except OSError as exc:  # a name too long for the file system, a folder that cannot be searched
        raise ScenarioError(f"{clean(name_or_path)}: cannot be read ({exc.strerror})") from None
    raise ScenarioError(f"{clean(name_or_path)}: no such scenario file or shipped scenario (see 'autobal list')")


def _set(data: dict, path: str, value) -> None:
    """Set the key at the dotted ``path`` of a scene mapping (list items by index), making the
    mappings on the way; a string value is read as YAML ("3" -> 3, "0.18 mm" stays a string)."""
    if isinstance(value, str):
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError:
            pass
    elif hasattr(value, "units") and hasattr(value, "magnitude"):  # a pint Quantity
        value = f"{value.magnitude!r} {value.units}"
    keys = path.split(".")
    node = data
    for i, key in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(node, list):
            if not key.isdigit() or int(key) >= len(node):
                raise ScenarioError(f"set {path}: {'.'.join(keys[:i])} has no item {key}")
            key = int(key)
        elif not isinstance(node, dict):
            raise ScenarioError(f"set {path}: {'.'.join(keys[:i]) or '(top level)'} is not a mapping")
        elif not last and node.get(key) is None:
            node[key] = {}
        if last:
            node[key] = value
        else:
            node = node[key]


class _UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses a key given twice in one mapping (PyYAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise yaml.constructor.ConstructorError(None, None, "a key must be a plain value",
                                                        key_node.start_mark) from None
            if key in seen:
                raise ScenarioError(f"duplicate key {key!r} at line {key_node.start_mark.line + 1} "
                                    f"(first at line {seen[key]})")
            seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


def _count(node, budget: list[int]) -> None:
    budget[0] -= 1
    if budget[0] < 0:
        raise ScenarioError(f"more than {MAX_NODES} values (YAML aliases expanded): not a scene")
    children = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
    for child in children:
        _count(child, budget)


def read(path: Path) -> dict:
    """The YAML mapping of a scenario file, checked as text: UTF-8, not binary, at most
    :data:`MAX_FILE_BYTES`, no duplicate keys; ScenarioError with one line otherwise.

    Parameters
    ----------
    path : Path
        The scenario file.

    Returns
    -------
    dict
        The parsed scene, not yet validated.
    """
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ScenarioError(f"{path}: {size} bytes: a scenario is a YAML text of at most {MAX_FILE_BYTES} bytes")
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if b"\0" in raw[:8192]:
        raise ScenarioError(f"{path}: a binary file, not a YAML scenario")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            f"save the scenario as UTF-8") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: a scenario is a YAML mapping of keys to values")
    try:
        _count(data, [MAX_NODES])
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    return data


def _checked_overrides(overrides) -> dict:
    """A copy of the overrides mapping after checking its type, its keys (dotted paths) and its values (a string,
    number, bool, None, pint quantity, or a list or mapping of these as YAML gives them); ScenarioError otherwise."""
    if overrides is None:
        return {}
    if not isinstance(overrides, Mapping):
        raise ScenarioError(f"set: a mapping of dotted scene paths to values, e.g. {{'device.disc.face.base_gap': "
                            f"'0.18 mm'}}; got {type(overrides).__name__}")
    for key, value in overrides.items():
        if not isinstance(key, str) or not key.strip() or any(not k for k in key.split(".")):
            raise ScenarioError(f"set: {key!r} is not a dotted scene path such as 'device.disc.face.base_gap'")
        if not _plain(value) and not (hasattr(value, "units") and hasattr(value, "magnitude")):
            raise ScenarioError(f"set {key}: a value of type {type(value).__name__} is not a scene value (give a "
                                "string with its unit, a number, a list or a mapping)")
    return dict(overrides)


def _plain(value) -> bool:
    """A value YAML could have given: str, a real number (bool too), None, lists and string-keyed mappings of them."""
    if value is None or isinstance(value, str | numbers.Real):
        return True
    if isinstance(value, list | tuple):
        return all(_plain(v) for v in value)
    if isinstance(value, Mapping):
        return all(isinstance(k, str) and _plain(v) for k, v in value.items())
    return False


def load(name_or_path: str | Path, overrides: dict | None = None) -> BaseScenario:
    """Read, validate and convert a scenario to SI; raise ScenarioError with one line.

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario.
    overrides : dict, optional
        Dotted scene paths -> values (``{"device.disc.face.base_gap": "0.18 mm"}``), applied to
        the file's content before validation, so they are checked exactly like YAML.

    Returns
    -------
    Scenario
        The validated scene, every quantity in SI.
    """
    overrides = _checked_overrides(overrides)
    path = resolve(name_or_path)
    data = read(path)
    for key, value in overrides.items():
        _set(data, key, value)
    try:
        scn = model_for(data).model_validate(data, context={"folder": path.absolute().parent, "overrides": overrides})
    except ValidationError as exc:
        loc = ".".join(str(p) for p in exc.errors()[0]["loc"])
        hit = next((k for k in overrides if loc == k or loc.startswith(k + ".") or (loc and k.startswith(loc + "."))),
                   None)
        where = f"set {clean(hit)}={clip(str(overrides[hit]))}" if hit else clean(path)
        raise ScenarioError(f"{where}: {_one_line(exc)}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    scn._origin = {"file": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                   "overrides": {k: str(v) for k, v in overrides.items()}}
    return scn


def shipped() -> list[Path]:
    return sorted(SCENARIO_DIR.glob("*.yaml"))


# ---- predicted run time ----------------------------------------------------------------------------------
# Seconds per unit of work on one core of the reference machine (a 2-core x86-64 laptop), calibrated on the
# shipped scenes; an estimate within a factor of about 3, for warning before long runs, not a measurement.
COST = {
    "start": 1.0,  # building the solvers of an analysis
    "ipopt_solve": 4e-3,  # one warm-started IPOPT solve of the device statics (sweep, force-gap point)
    "mc_statics_sample": 1.5e-5,  # one Monte Carlo sample at one discharge ratio (mapped Newton)
    "mc_afc_point": 1.5e-6,  # one Monte Carlo sample at one frequency (linear model)
    "afc_point": 2e-4,  # one frequency of one model's AFC
    "map_point": 3e-3,  # one point of a stability map, per model
    "transient_point": 5e-4,  # one output time of one time response (CVODES)
    "ocp_collocation_point": 5e-3,  # one collocation point of the spin-up OCP, per start
    "robust_validation_run": 4e-3,  # one profile on one validation rotor (exponential integrator)
    "modal_ocp_point": 0.02,  # one collocation point of the multi-mode (ROSS) spin-up OCP, per start
    "reliability_node": 5e-7,  # one (time, load) node of the reliability integrals
    "rotor_run": 0.5,  # one CVODES passage / step response of the rotor studies
    "grid_point": 1e-5,  # one point of a dense cross-check grid
    "fit": 2.0,  # one least-squares fit with its cross-checks
    "fit_point": 1e-4,  # one data row of a fit, its cross-check and its results (100,000 rows: 10 s CPU measured)
    "bootstrap_point": 1.5e-6,  # one data row of one bootstrap refit (1000 rows x 2000 samples: 2.7 s CPU)
}
LONG_RUN_S = 60.0  # a run predicted to take longer says so first


def estimate_seconds(scn: BaseScenario) -> dict[str, float]:
    """Predicted wall time of each analysis of a scene, by a per-analysis cost model (:data:`COST`).

    Parameters
    ----------
    scn : Scenario
        A validated scene.

    Returns
    -------
    dict
        Analysis name -> predicted time, s (single core; an estimate within a factor of about 3).
    """
    from autobal.analysis.statics_study import PATH_NODES

    c, a, out = COST, scn.analyses, {}
    if a.statics is not None:
        n = a.statics.discharge_ratio.points
        out["statics"] = c["start"] + c["ipopt_solve"] * (n + (PATH_NODES if n > PATH_NODES else 0)
                                                          + a.statics.force_gap_points)
    if a.frequency is not None:
        out["frequency"] = c["start"] + c["afc_point"] * a.frequency.omega.points * len(a.frequency.models)
    if a.stability is not None:
        m = a.stability.map
        out["stability"] = c["start"] + (c["map_point"] * m.x.points * m.y.points * len(m.models) if m else 0.0)
    if a.transient is not None:
        out["transient"] = c["start"] + c["transient_point"] * a.transient.points * len(a.transient.cases)
    if a.montecarlo is not None:
        mc = a.montecarlo
        t = c["start"] + c["mc_statics_sample"] * mc.samples * len(mc.discharge_ratio)
        if mc.afc is not None:
            t += c["start"] + c["mc_afc_point"] * mc.afc.samples * mc.afc.omega.points
        out["montecarlo"] = t
    if a.spinup is not None:
        s = a.spinup
        out["spinup"] = c["start"] + c["ocp_collocation_point"] * s.intervals * s.degree * (4 if s.multistart else 1)
    if a.spinup_robust is not None:
        s = a.spinup_robust
        out["spinup_robust"] = (c["start"] + c["ocp_collocation_point"] * s.intervals * s.degree * 12
                                + c["robust_validation_run"] * s.validation_samples * (s.ramps + 2))
    if a.spinup_time_optimal is not None:
        s = a.spinup_time_optimal
        out["spinup_time_optimal"] = c["start"] + c["ocp_collocation_point"] * s.intervals * s.degree * (
            4 + 2 * s.front_points)
    if a.ross_spinup is not None:
        s = a.ross_spinup
        # ROSS's import, numba compilation and critical speeds (about 30 s), then the four-phase search (about
        # 5 s) and its starts on the modal envelope (4 modes, 160 intervals of degree 3: about 24 s measured)
        out["ross_spinup"] = 30.0 * s.validate_with_ross + c["start"] + c["modal_ocp_point"] * s.intervals \
            * s.degree * 2
    if a.reliability is not None:
        r = a.reliability
        out["reliability"] = c["start"] + c["reliability_node"] * r.time_points * r.tau_nodes
    if a.rotor_dynamics is not None:
        rd, runs = a.rotor_dynamics, 0
        runs += len(rd.steps.psi) * len(rd.steps.steps) if rd.steps else 0
        runs += len(rd.passage.psi) * len(rd.passage.friction) * (2 if rd.passage.crossover else 1) if rd.passage else 0
        runs += len(rd.lewis.zeta) * len(rd.lewis.accel_ratio) if rd.lewis else 0
        runs += 1 if rd.motor_runup else 0
        out["rotor_dynamics"] = c["start"] + c["rotor_run"] * runs
    if a.liquid_balancer is not None:
        lb = a.liquid_balancer
        grid = sum(s.grid_points for s in (lb.height, lb.volume) if s is not None)
        out["liquid_balancer"] = c["start"] + c["grid_point"] * grid * (1 + len(lb.unbalance_masses) + len(lb.liquids))
    if a.estimation is not None:
        e = a.estimation
        disc = sum(f.model == "traditional_disc" for f in e.fits)
        out["estimation"] = c["start"] + (c["fit"] + c["fit_point"] * e.points) * len(e.fits) \
            + (c["bootstrap_point"] * e.points * e.bootstrap.samples * disc if e.bootstrap else 0.0)
    return out


def long_run_note(scn: BaseScenario) -> str | None:
    """One line to print before a run predicted to take more than :data:`LONG_RUN_S`, else None.

    Parameters
    ----------
    scn : Scenario
        A validated scene.

    Returns
    -------
    str or None
        E.g. "this run is estimated to take about 7 min (statics 6.8 min, ...)".
    """
    est = estimate_seconds(scn)
    total = sum(est.values())
    if total <= LONG_RUN_S:
        return None

    def fmt(s):
        return f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"

    parts = ", ".join(f"{k} {fmt(v)}" for k, v in sorted(est.items(), key=lambda kv: -kv[1]))
    return f"this run is estimated to take about {fmt(total)} ({parts})"
