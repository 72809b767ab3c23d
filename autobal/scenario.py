"""Scenario files: YAML scenes with units, validated into SI at load time.

Every field is documented in README.md ("Scenario format").  A bad file raises
:class:`autobal.errors.ScenarioError` with one line naming the file, the field and the
expected unit.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import Field, PrivateAttr, ValidationError, model_validator

from autobal.errors import ScenarioError
from autobal.paths import SCENARIO_DIR
from autobal.schema import NonNegative, Positive, Range, Strict
from autobal.schema_design import Design
from autobal.schema_dynamics import Dynamics, Frequency, Stability, Transient
from autobal.schema_estimation import Estimation
from autobal.schema_liquid_balancer import LiquidBalancer, LiquidBalancerAnalysis
from autobal.schema_reliability import Executor, MonteCarlo, Reliability
from autobal.schema_rotor import Rotor, RotorDynamics, Spinup
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
)


class Fluid(Strict):
    density: Density  # liquid density, or gas density at normal conditions
    viscosity: Viscosity
    normal_pressure: Pressure | None = None  # gas only: pressure of normal conditions (2.128)


class Impeller(Strict):
    """Impeller data for the axial-force ratio b (2.18), App. A L3125."""

    hub_radius: Length  # R0
    shroud_radius: Length  # R1
    outer_radius: Length  # R2
    stages: Annotated[int, Field(ge=1)]
    speed: AngularSpeed


class Operating(Strict):
    nominal_pressure: Pressure  # p_n = p_B
    nominal_thrust: Force  # T_n; s_B = T_n / p_n
    nominal_flow: VolumeFlow | None = None  # Q_n, for Q_e / Q_n
    drain_pressure: PressureOrZero = 0.0  # p4
    thrust_ratio: Positive | None = None  # b in tau = b psi1; from the impeller when omitted
    impeller: Impeller | None = None

    @model_validator(mode="after")
    def _b_given(self):
        if self.thrust_ratio is None and self.impeller is None:
            raise ValueError("give thrust_ratio (b) or impeller data to compute it")
        return self


class InnerSeal(Strict):
    """Laminar annular bushing seal, g1 = pi d h^3 / (12 mu l)."""

    diameter: Length
    length: Length
    clearance: Length


class OuterSeal(Strict):
    """Square-root-law annular seal, zeta = zeta_local + lambda l / (2h)."""

    diameter: Length
    length: Length
    clearance: Length
    local_loss: NonNegative = 1.5
    friction: Positive = 0.06


class Face(Strict):
    """Face throttle between the disc and the pad; conductance g_TB u^(3/2)."""

    inner_diameter: Length
    outer_diameter: Length
    base_gap: Length  # z_B = h_TB
    friction: Positive = 0.06

    @model_validator(mode="after")
    def _annulus(self):
        if self.outer_diameter <= self.inner_diameter:
            raise ValueError("outer_diameter must be larger than inner_diameter")
        return self


class Disc(Strict):
    inner_seal: InnerSeal
    face: Face
    outer_seal: OuterSeal
    pushoff_force: ForceOrZero = 0.0  # F_pr

    @model_validator(mode="after")
    def _seal_inside_face(self):
        if self.inner_seal.diameter >= self.face.inner_diameter:
            raise ValueError("inner_seal.diameter must be smaller than face.inner_diameter")
        return self


class Tube(Strict):
    """Laminar round tube, g = pi d^4 / (192 mu l) (source coefficient)."""

    diameter: Length
    length: Length


class Barrier(Strict):
    supply_throttle: Tube
    margin_ratio: Positive  # dpsi = (p_e - p1) / p_B, the regulator set-point


class Valve(Strict):
    seat_diameter: Length
    base_opening: Length  # x_B
    discharge_coefficient: Annotated[float, Field(gt=0, le=1)] = 0.54
    max_opening: Length | None = None  # valve travel limit; unlimited when omitted


class Regulator(Strict):
    supply_pressure: Pressure  # p_in
    inlet_throttle: Tube
    valve: Valve
    membrane_area: Area


class Device(Strict):
    medium: Literal["liquid", "gas"]
    fluid: Fluid
    operating: Operating
    disc: Disc
    barrier: Barrier
    regulator: Regulator | None = None
    dynamics: Dynamics | None = None  # masses, springs, volumes: analyses frequency/stability/transient

    @model_validator(mode="after")
    def _gas_needs_normal_pressure(self):
        if self.medium == "gas" and self.fluid.normal_pressure is None:
            raise ValueError("fluid.normal_pressure is required for a gas (Pa, e.g. '0.1 MPa')")
        return self


class Statics(Strict):
    """Static calculation: operating point, sweep over discharge pressure, criticals."""

    operating_ratio: Positive = 1.0  # psi1 = p1 / p_B of the reported operating point
    discharge_ratio: Range  # sweep of psi1 for Figs 2.4-2.6
    force_gap_points: Annotated[int, Field(ge=2)] = 60  # phi(u) characteristic (2.35)


class Analyses(Strict):
    statics: Statics | None = None
    frequency: Frequency | None = None  # autobal/schema_dynamics.py; need device.dynamics
    stability: Stability | None = None
    transient: Transient | None = None
    liquid_balancer: LiquidBalancerAnalysis | None = None  # autobal/schema_liquid_balancer.py; needs liquid_balancer
    estimation: Estimation | None = None  # autobal/schema_estimation.py; device model fits need device
    montecarlo: MonteCarlo | None = None  # autobal/schema_reliability.py; needs device
    reliability: Reliability | None = None  # autobal/schema_reliability.py; traditional disc, ch. 1.2
    rotor_dynamics: RotorDynamics | None = None  # autobal/schema_rotor.py; needs rotor
    spinup: Spinup | None = None  # autobal/schema_rotor.py; optimal spin-up OCP, needs rotor
    design: Design | None = None  # autobal/schema_design.py; stability-constrained design, needs device.dynamics


# analysis -> the part of the scene it needs (a dotted path), checked at load time
NEEDS = {
    "statics": "device", "frequency": "device.dynamics", "stability": "device.dynamics",
    "transient": "device.dynamics", "montecarlo": "device", "liquid_balancer": "liquid_balancer",
    "rotor_dynamics": "rotor", "spinup": "rotor", "design": "device.dynamics",
}


class Scenario(Strict):
    name: str
    title: str
    source: str = ""
    device: Device | None = None  # the axial balancing device (statics, dynamics, Monte Carlo, fits)
    liquid_balancer: LiquidBalancer | None = None  # liquid auto-balancer (autobal/schema_liquid_balancer.py)
    rotor: Rotor | None = None  # Jeffcott rotor with optional liquid layer and drive (autobal/schema_rotor.py)
    executor: Executor | None = None  # where sweeps and Monte Carlo run (autobal/schema_reliability.py)
    analyses: Analyses
    _origin: dict = PrivateAttr(default_factory=dict)  # file, sha256, overrides (set by load)

    @model_validator(mode="after")
    def _parts_for_analyses(self):
        for analysis, path in NEEDS.items():
            if getattr(self.analyses, analysis) is None:
                continue
            node = self
            for part in path.split("."):
                node = getattr(node, part, None)
            if node is None:
                raise ValueError(f"analyses.{analysis} needs a {path} section")
        return self


def _one_line(err: ValidationError) -> str:
    e = err.errors()[0]
    where = ".".join(str(p) for p in e["loc"]) or "(top level)"
    msg = e["msg"].removeprefix("Value error, ")
    if e["type"] == "extra_forbidden":
        msg = "unknown key"
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    return f"{where}: {msg}{more}"


def resolve(name_or_path: str | Path) -> Path:
    """A scenario path, or the name of a shipped scenario (``scenarios/NAME.yaml``)."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    shipped = SCENARIO_DIR / f"{p.stem}.yaml"
    if p.suffix in ("", ".yaml") and shipped.is_file() and p.parent == Path("."):
        return shipped
    raise ScenarioError(f"{name_or_path}: no such scenario file or shipped scenario (see 'autobal list')")


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


def load(name_or_path: str | Path, overrides: dict | None = None) -> Scenario:
    """Read, validate and convert a scenario to SI; raise ScenarioError with one line.

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario.
    overrides : dict, optional
        Dotted scene paths -> values (``{"device.disc.face.base_gap": "0.18 mm"}``), applied to
        the file's content before validation, so they are checked exactly like YAML.
    """
    path = resolve(name_or_path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: a scenario is a YAML mapping of keys to values")
    overrides = dict(overrides or {})
    for key, value in overrides.items():
        _set(data, key, value)
    try:
        scn = Scenario.model_validate(data)
    except ValidationError as exc:
        loc = ".".join(str(p) for p in exc.errors()[0]["loc"])
        hit = next((k for k in overrides if loc == k or loc.startswith(k + ".")), None)
        where = f"set {hit}={overrides[hit]}" if hit else str(path)
        raise ScenarioError(f"{where}: {_one_line(exc)}") from None
    scn._origin = {"file": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                   "overrides": {k: str(v) for k, v in overrides.items()}}
    return scn


def shipped() -> list[Path]:
    return sorted(SCENARIO_DIR.glob("*.yaml"))
