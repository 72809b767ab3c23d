"""``autobal explore SCENE``: a live what-if page of a scene (Bokeh server on 127.0.0.1, the ``explore`` extra).

One slider per parameter the scene writes in its ``device`` section, in the scene's own units and within the
bounds the parameter's declaration gives; every change re-solves the scene's device through the fast paths of
the same models and solvers the batch run uses:

- statics: the Newton solve of the device's balances with every dimensionless group as a parameter
  (:class:`autobal.analysis.numerics.statics.ParametricStatics`, the batch solver of sweeps and Monte Carlo),
  warm-started from the previous point; on release of a slider IPOPT
  (:class:`~autobal.analysis.numerics.statics.StaticsSolver`, what ``autobal run`` solves) cross-checks it, and its
  answer is shown where it differs;
- dynamics: the exact Jacobians of the nonlinear model (:func:`autobal.models.dynamics.build`) built once with the
  groups and scales as symbols, so a change is one call of the Jacobian Function, not a rebuild; poles and
  verdict by :func:`autobal.analysis.numerics.stability.verdict`; the AFC on the grid of
  :func:`autobal.analysis.numerics.frequency.grid` from one eigen-decomposition, H(jw) = C V (jw - Lambda)^-1 V^-1 B,
  its peaks refined by :func:`autobal.analysis.numerics.frequency.peaks`, as the batch run refines them.

A device-statics scene (``analyses.statics``, no ``device.dynamics``) gets the device's sliders and the statics
study's answers: the operating point, the critical discharge pressure p1_kr and barrier margin dp_kr (Q_1 = 0, by
Newton on the same balances with the pressure as an unknown), the static characteristic over the scene's grid (the
parametric Newton roots, every stop set) and the study's verdict
(:func:`autobal.analysis.studies.statics_study.verdict`).

A spin-up scene (``analyses.spinup``) gets the rotor's sliders: its critical speed with the API 684 AF and SM
(:func:`autobal.analysis.studies.rotor_study.api_margins`, as the spin-up study), the current optimum's speed profile
and the constant ramps (``baselines``) re-simulated for the changed rotor by its exact linear response
(:mod:`autobal.ocp.linear_response`; CVODES, :func:`autobal.ocp.simulation.resimulate`, the cross-check once the
sliders rest), and "re-optimise" (the batch run's optimisation, in a thread).

"save scene" writes the settings as a YAML scene with units that ``autobal run`` reproduces; "report" runs
``autobal.run`` on it and writes its report.html.  :class:`DeviceExplorer`, :class:`StaticsExplorer` and
:class:`SpinupExplorer` are the computations (no Bokeh); :func:`serve` the page.
"""

from __future__ import annotations

import copy
import dataclasses
import html
import math
import re
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np
import yaml

from autobal import scenario
from autobal.analysis.numerics import frequency as fr
from autobal.analysis.numerics import stability as st
from autobal.analysis.numerics.linearize import LinearModel
from autobal.analysis.numerics.statics import RESIDUAL_TOL, ParametricStatics, StaticsSolver, ideal_guess
from autobal.analysis.run import solver_options
from autobal.errors import AutobalError, ScenarioError, SolveError
from autobal.models import device as dv
from autobal.models.dynamics import build
from autobal.parts import derived
from autobal.parts.device import adapt, design
from autobal.schema import section_at
from autobal.units import to_si

HOST = "127.0.0.1"
#: scales of the device design that enter the dynamic model (symbols of the one built model)
MODEL_SCALES = ("p_B", "s_B", "z_B", "x_B", "g1", "s_e")
MODELS_KEPT = 8  # dynamic models kept built (one per structure: medium, regulator, margin)
SLIDER_SPAN = 5.0  # a slider runs from value / SPAN to value * SPAN, inside the declared bounds
SLIDER_STEPS = 400
CHECK_RTOL = 1e-6  # IPOPT's operating point differs from Newton's when a value differs by more than this
# CVODES's re-simulation (at the batch run's tolerance) differs from the spin-up page's linear response when a peak
# differs by more than this relative amount, or its time by more than SPINUP_CHECK_T seconds (tests/
# test_explore_linear_response.py: they agree to 1e-9 and 1e-7 s over a range of rotors and drives)
SPINUP_CHECK_RTOL = 1e-8
SPINUP_CHECK_T = 1e-6
CHECK_AFTER_S = 1.0  # IPOPT cross-checks a setting once the sliders have rested this long
CRITICAL_RTOL = 1e-12  # Brent's method's relative tolerance on the criticals psi1_kr, dpsi_kr
PSI1_MAX = 100.0  # the largest discharge ratio a scene may give (analyses.statics): psi1_kr is looked for up to it
DPSI_MIN, DPSI_MAX = 1e-6, 100.0  # the margins dpsi_kr is looked for between (IPOPT's lower bound: 1e-6)
DRIVE_SETTINGS = ("max_acceleration",)  # analyses.spinup settings slid beside the rotor: the drive's limit
WALK_FACTOR = 3.0  # where the characteristic has no sign change of q1, it is followed in steps of this factor
NEEDS = ("explore needs a scene with device.dynamics (e.g. pump_pe600_dynamics), a device with analyses.statics "
         "(pump_pe600_statics) or a rotor with analyses.spinup (spinup_jeffcott_deadline_5s)")
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


# ---- the parameters of a scene --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Parameter:
    """One slider: a scene path, its quantity kind (None: dimensionless), the scene's unit and value in it, and
    the slider's range in that unit (inside the declared bounds)."""

    path: str
    kind: str | None
    unit: str
    value: float
    start: float
    end: float
    doc: str

    def si(self, value: float) -> float:
        """``value`` in the scene's unit -> SI, by the same conversion that loads a scene."""
        return float(value) if self.kind is None else to_si(self.text(value), self.kind)

    def text(self, value: float) -> str:
        """``value`` as the scene writes it: the number (round-trip exact) and the unit."""
        return f"{float(value)!r} {self.unit}".strip()

    @property
    def label(self) -> str:
        return f"{self.path.removeprefix('device.')} ({self.unit or '1'})"


def _raw_at(raw: dict, path: str):
    node = raw
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def _slider_range(value: float, bounds: dict) -> tuple[float, float]:
    if value == 0:
        start, end = 0.0, 1.0
    else:
        start, end = sorted((value / SLIDER_SPAN, value * SLIDER_SPAN))
    lo = bounds.get("ge", bounds.get("gt"))
    hi = bounds.get("le", bounds.get("lt"))
    if lo is not None:
        start = max(start, lo if "ge" in bounds else lo + (end - start) / SLIDER_STEPS)
    if hi is not None:
        end = min(end, hi)
    return start, end


def parameters(section, raw: dict, prefix: str) -> list[Parameter]:
    """The sliders of a validated scene section: every number it writes (``raw``: the scene as read) whose field
    is declared with a unit in the models' parameter dataclasses (:mod:`autobal.parts.derived`)."""
    cls = next(derived._PARAMS[c] for c in type(section).__mro__ if c in derived._PARAMS)
    out = []
    for f in dataclasses.fields(cls):
        key = derived.key(f)
        if key is None:
            continue
        value, path = section_at(section, key), f"{prefix}.{key}"
        if value is None:
            continue
        if "unit" not in f.metadata:  # a nested part: its own declarations
            if dataclasses.is_dataclass(f.type) or type(value) in derived._PARAMS or any(
                    c in derived._PARAMS for c in type(value).__mro__):
                out += parameters(value, raw, path)
            continue
        written = _raw_at(raw, path)
        if isinstance(written, bool) or f.type in ("int", int) or isinstance(value, int) and not isinstance(
                written, str):
            continue  # counts (stages) are not slid
        kind = f.metadata["kind"]
        if kind is None and isinstance(written, int | float):
            number, unit = float(written), ""
        elif kind is not None and isinstance(written, str) and (m := _NUMBER.fullmatch(written)) and m.group(2):
            number, unit = float(m.group(1)), m.group(2)
        else:
            continue
        start, end = _slider_range(number, f.metadata["bounds"])
        out.append(Parameter(path, kind, unit, number, start, end, f.metadata.get("doc", "")))
    return out


def setting(settings, raw: dict, path: str) -> Parameter | None:
    """The slider of a quantity of an analysis' validated ``settings`` (``path``: its scene path) as the scene
    writes it (``raw``), from its field's declared kind (:func:`autobal.units.quantity`); None where the scene
    does not write it with a unit."""
    field = type(settings).model_fields[path.rsplit(".", 1)[1]]
    kind = (field.json_schema_extra or {}).get("kind") if isinstance(field.json_schema_extra, dict) else None
    written = _raw_at(raw, path)
    if kind is None or not isinstance(written, str) or not (m := _NUMBER.fullmatch(written)) or not m.group(2):
        return None
    number = float(m.group(1))
    return Parameter(path, kind, m.group(2), number, *_slider_range(number, {"gt": 0.0}), field.description or "")


def _with(model, path: str, value):
    """A copy of the pydantic ``model`` with the dotted ``path`` set to ``value`` (no validation: the slider
    keeps each value inside its bounds; the dataclasses' own checks run when the section is adapted)."""
    head, _, rest = path.partition(".")
    new = _with(getattr(model, head), rest, value) if rest else value
    return model.model_copy(update={head: new})


# ---- the live computation -------------------------------------------------------------------------------------

class Settings:
    """A scene and its sliders: the settings (scene path -> value in the scene's unit), the section they make,
    the scene they write."""

    def __init__(self, source: str | Path):
        self.source = str(source)  # as the user named it: a shipped scene's name or a file
        self.path = scenario.resolve(source)
        self.raw = scenario.read(self.path)
        self.scene = scenario.load(self.path)
        self.params: list[Parameter] = []

    @property
    def by_path(self) -> dict:
        return {p.path: p for p in self.params}

    def defaults(self) -> dict:
        """Scene path -> value in the scene's unit, as the scene writes it."""
        return {p.path: p.value for p in self.params}

    def section(self, part: str, values: dict):
        """The scene's validated section ``part`` with the settings ``values`` (path -> scene unit) in SI."""
        section, by_path = getattr(self.scene, part), self.by_path
        for path, v in values.items():
            p = by_path[path]
            if v != p.value and path.startswith(part + "."):
                section = _with(section, path.removeprefix(part + "."), p.si(v))
        return section

    def overrides(self, values: dict) -> dict:
        """The changed settings as ``--set`` overrides: path -> text with the scene's unit."""
        by_path = self.by_path
        return {k: by_path[k].text(v) for k, v in values.items() if v != by_path[k].value}

    def scene_yaml(self, values: dict) -> str:
        """The scene with the settings written in, as YAML with units (``autobal run`` reproduces it)."""
        data = copy.deepcopy(self.raw)
        for k, text in self.overrides(values).items():
            scenario._set(data, k, text)
        head = f"# written by autobal explore from {self.path.name}\n"
        return head + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)

    def save(self, values: dict, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.scene_yaml(values))
        return path


class DeviceSettings(Settings):
    """A device scene's sliders and the fast path of its statics (both device pages): the device of the settings,
    the parametric balances built once per structure, Newton's operating point warm-started from the last one."""

    psi1 = 1.0  # the discharge ratio p1 / p_B of the operating point

    def __init__(self, source: str | Path):
        super().__init__(source)
        self._statics_cache: dict = {}  # structure key -> (ParametricStatics, group names)
        self._last = None  # (active set, W) of the last solved point: the warm start

    def device(self, values: dict):
        """DeviceParams (SI) of the settings ``values`` (path -> scene unit), by the scene's adapter."""
        return adapt(self.section("device", values))

    # -- the fast path
    def _statics(self, dd: dv.DeviceDesign) -> tuple[ParametricStatics, tuple]:
        """The device's balances with every group as a parameter, built once per structure (what the groups
        cannot carry: the medium, the regulator and its valve's travel limit, the bounds of the unknowns)."""
        g = dd.groups
        key = (g.medium, g.regulator is not None, g.regulator.xi_max if g.regulator else None)
        if key not in self._statics_cache:
            names = tuple(dv.groups_by_name(g))
            self._statics_cache[key] = (ParametricStatics(g, names), names)
        return self._statics_cache[key]

    def _setting(self, values: dict) -> tuple:
        """(DeviceParams, DeviceDesign, operating point :meth:`_point`) of the settings; where the device refuses
        them or the statics have no solution, (None, the answer saying so, None)."""
        try:
            dev = self.device(values)
            dd = dv.design(dev)
        except (ValueError, ZeroDivisionError, AutobalError) as exc:
            return None, {"status": "refused", "message": str(exc)}, None
        try:
            return dev, dd, self._point(dd)
        except SolveError as exc:
            return None, {"status": "no_statics", "message": f"the statics have no solution at this setting (IPOPT: "
                                                             f"{exc.status})"}, None

    def stop_sets(self, statics: ParametricStatics) -> list:
        """The stop sets Newton's roots are tried with, in turn: regulating, the valve on its stop."""
        return statics.active_sets

    def _point(self, dd: dv.DeviceDesign) -> dict:
        """The operating point: Newton's root of the balances at the groups of ``dd``, warm-started from the last
        point (its stop set and unknowns), then from the closed form with each stop set; where none is accepted,
        IPOPT with every stop (SolveError when it fails too)."""
        statics, names = self._statics(dd)
        g = dd.groups
        theta = [dv.groups_by_name(g)[n] for n in names]
        P = np.array([[self.psi1, dd.dpsi, *theta]])
        guess = ideal_guess(g, statics.system.unknowns, self.psi1, dd.dpsi)
        last = self._last if self._last is not None and self._last[1].shape == guess[0].shape else None
        attempts = ([(last[0], np.atleast_2d(last[1]))] if last is not None else []) + [
            (a, guess) for a in self.stop_sets(statics)]
        res = statics.solve(P, attempts)
        if res["valid"][0]:
            W = res["W"][0]
            active = attempts[res["active"][0]][0]
            vals = dict(zip(statics.system.unknowns, map(float, W), strict=True))
            vals.setdefault("psi_e", self.psi1 + dd.dpsi)
            flows = dict(zip(statics.system.throttles, map(float, res["q"][0]), strict=True))
        else:
            sp = StaticsSolver(dd).solve(self.psi1, dd.dpsi)
            W, active, vals, flows = np.asarray(sp.x, float), sp.active, dict(sp.values), sp.flows
        self._last = (active, W.copy())
        return vals | {"_flows": flows, "_active": active, "_names": names}

    def _operating_point(self, pt: dict, dd: dv.DeviceDesign) -> dict:
        sc, q = dd.scales, pt["_flows"]
        pressures = {k: pt[k] * sc["p_B"] for k in ("psi2", "psi3", "psi_e", "psi_cam") if k in pt}
        return {"gap": pt["u"] * sc["z_B"], "pressures": pressures, "leak": q["e"] * sc["Q_scale"],
                "inner_seal_flow": q["1"] * sc["Q_scale"], "valve_opening": pt.get("xi", math.nan) * sc["x_B"],
                "point": {k: v for k, v in pt.items() if not k.startswith("_")}}

    # -- the cross-check on release
    def check(self, values: dict, answer: dict) -> str:
        """The scene validated as a file would be (``autobal.load`` with the settings as overrides) and its
        operating point by IPOPT (what ``autobal run`` solves) against the live answer; '' when they agree."""
        try:
            scene = scenario.load(self.path, overrides=self.overrides(values))
            dd = design(scene.device)
            point = StaticsSolver(dd).solve(self.psi1, dd.dpsi)
        except ScenarioError as exc:
            return f"refused by the scene's checks: {exc}"
        except SolveError as exc:
            return f"IPOPT: {exc} (status {exc.status})"
        if answer.get("status") != "ok" and "point" not in answer:
            return f"IPOPT finds an operating point (gap {point.values['u'] * dd.scales['z_B'] * 1e6:.6g} µm) " \
                   "where the fast path found none"
        live = answer["point"]
        worst = max(abs(point.values[k] - live[k]) / max(abs(live[k]), 1e-12) for k in live if k in point.values
                    and not k.startswith("r_"))
        if worst > CHECK_RTOL:
            return (f"IPOPT's operating point differs (largest relative difference {worst:.1e}): gap "
                    f"{point.values['u'] * dd.scales['z_B'] * 1e6:.6g} µm")
        return ""


class DeviceExplorer(DeviceSettings):
    """The what-if computation of a device-dynamics scene: operating point, poles, verdict and AFC of the
    headline model (energy-consistent, physical forcing) for changed parameters.

    Parameters
    ----------
    source : str or Path
        A shipped scene name or a YAML file (what ``autobal.load`` takes).
    """

    def __init__(self, source: str | Path):
        super().__init__(source)
        sc = self.scene
        if getattr(sc, "device", None) is None or sc.device.dynamics is None:
            raise ScenarioError(f"{sc.name}: {NEEDS}")
        a = sc.analyses
        freq, stab = getattr(a, "frequency", None), getattr(a, "stability", None)
        self.psi1 = (freq or stab).operating_ratio if (freq or stab) is not None else 1.0
        o = freq.omega if freq is not None else None
        self.omega_range = (o.start, o.stop, o.points) if o is not None else (10.0, 8000.0, 600)
        self.required_decay = stab.decay_rate if stab is not None else 0.0
        self.params = parameters(sc.device, self.raw, "device") + parameters(sc.device.dynamics, self.raw,
                                                                              "device.dynamics")
        self._models: dict = {}  # structure key -> (Jacobian Function, model)

    def _model(self, dev: dv.DeviceParams, dd: dv.DeviceDesign, names: tuple, point: dict):
        """The nonlinear dynamic model with the groups, the scales and the membrane area as symbols d, and its
        Jacobians (x, w, p, d) -> (A, B), built once per structure: what the symbols cannot carry (the medium,
        the regulator, the margin dpsi and the point, which enter only its constant terms, the gas's p_n)."""
        g = dd.groups
        reg = g.regulator
        p_n = dev.dynamics.p_n
        key = (g.medium, reg is not None, dd.dpsi, None if math.isnan(p_n) else p_n)
        if key in self._models:
            return self._models[key]
        d = ca.SX.sym("d", len(names) + len(MODEL_SCALES) + 1)
        sym = dict(zip(names, ca.vertsplit(d[:len(names)]), strict=True))
        # b (tau = b psi1) enters the inputs only, which are given as numbers
        g_sym = dataclasses.replace(g, **{k: v for k, v in sym.items() if k in dv.DEVICE_GROUPS and k != "b"})
        if reg is not None:
            g_sym = dataclasses.replace(g_sym, regulator=dataclasses.replace(
                reg, **{k: v for k, v in sym.items() if k in dv.REGULATOR_GROUPS}))
        scales = dict(dd.scales) | dict(zip(MODEL_SCALES, ca.vertsplit(d[len(names):-1]), strict=True))
        data = dataclasses.replace(dev.dynamics, s_m=d[-1])
        model = build(dataclasses.replace(dd, groups=g_sym, scales=scales), data,
                      point | {"psi1": self.psi1, "dpsi": dd.dpsi}, "energy", symbols=d)
        x, w, p = ca.SX.sym("x", len(model.states)), ca.SX.sym("w", 2), ca.SX.sym("p", len(model.p0))
        f = model.ode(x, w, p, d)
        if len(self._models) >= MODELS_KEPT:  # a slid margin builds one per value: keep the latest few
            self._models.pop(next(iter(self._models)))
        self._models[key] = (ca.Function("AB", [x, w, p, d], [ca.jacobian(f, x), ca.jacobian(f, w)]), model)
        return self._models[key]

    def evaluate(self, values: dict) -> dict:
        """Operating point, poles, margin, verdict and AFC for the settings ``values`` (path -> scene unit).

        Returns a dict with ``status`` "ok", "refused" (a setting the device's declarations refuse), "no_statics"
        (no static solution, or the face in contact / the valve on its stop) or "failed"; ``message`` says why.
        """
        t0 = time.perf_counter()
        dev, dd, pt = self._setting(values)
        if pt is None:
            return dd
        sc = dd.scales
        out = {"status": "ok", "message": "", **self._operating_point(pt, dd)}
        if pt["_active"]:
            what = "face in contact" if "r_contact" in pt["_active"] else "regulator valve on its stop"
            return out | {"status": "no_statics", "message": f"operating point with the {what}: the dynamic model "
                                                             "needs an open gap and a regulating valve"}
        names = pt["_names"]
        jac, model = self._model(dev, dd, names, pt)
        x0 = np.array([0.0 if k in ("v", "w") else pt[k] for k in model.states])
        groups = dv.groups_by_name(dd.groups)
        d = [groups[n] for n in names] + [sc[k] for k in MODEL_SCALES] + [dev.dynamics.s_m]
        A, B = (np.array(m) for m in jac(x0, [self.psi1, dd.groups.b * self.psi1], dev.dynamics.vector(), d))
        S = np.diag([1.0 / model.t_ref if k in ("v", "w") else 1.0 for k in model.states])
        lin = LinearModel(label="nonlinear", A=S @ A @ np.linalg.inv(S), B=(S @ B)[:, ::-1],
                          states=[{"v": "du", "w": "dxi"}.get(k, k) for k in model.states],
                          b=dd.groups.b, z_B=sc["z_B"], u_out=0)
        out |= self._dynamics(lin, dev.dynamics)
        out["compute_ms"] = 1e3 * (time.perf_counter() - t0)
        return out

    def _dynamics(self, lin: LinearModel, data) -> dict:
        """Verdict (:func:`analysis.numerics.stability.verdict`) and the AFC of the face gap under the physical
        forcing."""
        v = st.verdict(lin, hurwitz=False)
        decay = v["margin"]["decay_rate"]
        ok = bool(v["stable"]) and decay >= self.required_decay
        lam, V = np.linalg.eig(lin.A)
        om = fr.grid(lin, *self.omega_range)
        bvec = lin.forcing("physical")
        left = np.linalg.solve(V, bvec)  # V^-1 b
        scale = data.forcing_amplitude * lin.z_B  # amplitudes in m, as results.json
        # modal sum: du(jw) = sum_k V[u, k] (V^-1 b)_k / (jw - lambda_k)
        amp = np.abs(((V[lin.u_out] * left)[:, None] / (1j * om[None, :] - lam[:, None])).sum(axis=0)) * scale
        peaks = fr.peaks(lin, om, amp, "physical", scale)
        w0 = data.omega0
        at = abs(lin.response([w0], "physical")[0]) * scale if np.isfinite(w0) else math.nan
        return {"poles": v["poles"], "damping_ratio": v["damping_ratio"], "stable": v["stable"],
                "decay_rate": decay, "min_damping_ratio": v["margin"]["min_damping_ratio"],
                "required_decay": self.required_decay, "meets_requirement": ok,
                "omega": om, "amplitude": amp, "peaks": peaks, "omega0": w0, "amplitude_at_omega0": at,
                "static_amplitude": float(abs(lin.response([0.0], "physical")[0]) * scale)}

class StaticsExplorer(DeviceSettings):
    """The what-if computation of a device-statics scene (``analyses.statics``): the operating point, the critical
    discharge pressure p1_kr and barrier margin dp_kr (the inner-seal flow q1 = 0, as the statics study's
    ``critical_exact``), the static characteristic over the scene's discharge ratios and the study's verdict
    (:func:`autobal.analysis.studies.statics_study.verdict`), all by Newton's roots of the parametric balances
    (the batch solver of sweeps); the criticals by Brent's method on q1 along psi1 (dpsi) over those roots."""

    def __init__(self, source: str | Path):
        super().__init__(source)
        sc = self.scene
        settings = getattr(sc.analyses, "statics", None)
        if getattr(sc, "device", None) is None or settings is None:
            raise ScenarioError(f"{sc.name}: {NEEDS}")
        self.psi1 = settings.operating_ratio
        r = settings.discharge_ratio
        self.grid = np.linspace(r.start, r.stop, r.points)
        self.psi1_max = r.stop
        self.params = parameters(sc.device, self.raw, "device")
        self._sweep = None  # the last sweep's rows of unknowns: its warm start
        self._critical_systems: dict = {}  # (structure, psi1 or dpsi, stops) -> the critical's Newton system

    def stop_sets(self, statics: ParametricStatics) -> list:
        """Regulating, the valve on its stop, and each with the face in contact (a point of the characteristic)."""
        return statics.active_sets + [a | {"r_contact"} for a in statics.active_sets]

    def _roots(self, dd: dv.DeviceDesign, psi1s, dpsis, starts=None, stops=frozenset()) -> dict:
        """Newton's roots at the rows (psi1, dpsi) (:meth:`ParametricStatics.solve`): from ``starts`` (rows of
        unknowns), then from the closed form, each with every stop set (``stops`` first, then regulating, valve on
        its stop, face in contact); ``stops`` per row: the stop set of the accepted root (None: no root)."""
        statics, names = self._statics(dd)
        groups = dv.groups_by_name(dd.groups)
        psi1s, dpsis = np.broadcast_arrays(np.atleast_1d(np.asarray(psi1s, float)), np.asarray(dpsis, float))
        P = np.column_stack([psi1s, dpsis, np.tile([groups[n] for n in names], (len(psi1s), 1))])
        unknowns = statics.system.unknowns
        guess = np.vstack([ideal_guess(dd.groups, unknowns, a, b) for a, b in zip(psi1s, dpsis, strict=True)]) \
            if np.ptp(dpsis) else ideal_guess(dd.groups, unknowns, psi1s, float(dpsis[0]))
        sets = [stops] + [a for a in self.stop_sets(statics) if a != stops]
        tries = ([np.where(np.isfinite(starts), starts, guess)] if starts is not None else []) + [guess]
        attempts = [(a, w) for w in tries for a in sets]
        res = statics.solve(P, attempts)
        res["stops"] = [attempts[k][0] if k >= 0 else None for k in res["active"]]
        res["q1"] = res["q"][:, statics.system.throttles.index("1")]
        return res

    def _continued(self, dd: dv.DeviceDesign, sw: dict) -> dict:
        """The characteristic's roots ``sw`` (:meth:`_roots` over the grid) with the points it has no root at solved
        again from the root of their nearest solved neighbour, pass by pass while that finds more (a continuation
        along the grid, as the batch sweep's: Newton from the closed form misses the face-contact branch where the
        closed form is far from it)."""
        for _ in range(len(self.grid)):
            good, bad = np.flatnonzero(sw["valid"]), np.flatnonzero(~sw["valid"])
            if not good.size or not bad.size:
                break
            near = good[np.abs(good[None, :] - bad[:, None]).argmin(axis=1)]
            res = self._roots(dd, self.grid[bad], dd.dpsi, starts=sw["W"][near])
            if not res["valid"].any():
                break
            for k in ("W", "q", "q1", "valid"):
                sw[k][bad[res["valid"]]] = res[k][res["valid"]]
            for i, j in zip(bad, range(len(bad)), strict=True):
                if res["valid"][j]:
                    sw["stops"][i] = res["stops"][j]
        return sw

    def _critical_system(self, dd: dv.DeviceDesign, which: str, stops: frozenset):
        """The balances with the stops fixed (as :meth:`ParametricStatics.newton`) and q1 = 0, square in the free
        unknowns and psi1 (``which`` "psi1") or dpsi ("dpsi"): CasADi's Newton rootfinder, built once per
        structure; ``(solver(z0, p) -> z, free indices, full(z) -> unknowns)``, z = [free unknowns, psi1 or dpsi];
        None where the system is structurally singular."""
        statics, names = self._statics(dd)
        key = (id(statics), which, stops)
        if key not in self._critical_systems:
            sys_ = statics.system
            free, fixed = statics.free(stops)
            z, p = ca.SX.sym("z", len(free) + 1), ca.SX.sym("p", 2 + len(names))
            full = ca.vertcat(*[z[free.index(i)] if i in free else fixed[i] for i in range(len(sys_.unknowns))])
            psi1, dpsi = (z[-1], p[1]) if which == "psi1" else (p[0], z[-1])
            q1 = statics.flows(full, psi1, dpsi, p[2:])[sys_.throttles.index("1")]
            f = ca.Function("critical", [z, p], [ca.vertcat(statics.residual(full, psi1, dpsi, p[2:]), q1)])
            try:
                solver = ca.rootfinder(f"critical_{which}", "newton", f, solver_options.rootfinder())
            except RuntimeError:  # structurally singular with these stops (q1 does not depend on the unknown)
                self._critical_systems[key] = None
            else:
                self._critical_systems[key] = (solver, free, ca.Function("full", [z], [full]))
        return self._critical_systems[key]

    def _critical(self, dd: dv.DeviceDesign, which: str, start: np.ndarray, stops: frozenset, guess: float,
                  bracket) -> float | None:
        """The psi1 (``which`` "psi1", at the scene's dpsi) or dpsi ("dpsi", at the operating psi1) where q1 = 0:
        Newton on the balances and q1 = 0 from the root ``start`` (its ``stops`` first, then each stop set) and
        ``guess``, a root accepted as :meth:`ParametricStatics.solve` accepts one; else Brent's method on q1 over
        Newton's roots inside ``bracket`` (q1 of opposite signs at its ends; None: no critical)."""
        from scipy.optimize import brentq

        statics, names = self._statics(dd)
        groups = dv.groups_by_name(dd.groups)
        p = [self.psi1, dd.dpsi, *(groups[n] for n in names)]
        for active in [stops] + [a for a in self.stop_sets(statics) if a != stops]:
            system = self._critical_system(dd, which, active)
            if system is None:
                continue
            solver, free, full = system
            z = np.asarray(solver(np.append(start[free], guess), p), float).ravel()
            if not np.all(np.isfinite(z)) or z[-1] <= 0 or bracket and not bracket[0] <= z[-1] <= bracket[1]:
                continue
            at = (z[-1], dd.dpsi) if which == "psi1" else (self.psi1, z[-1])
            res = self._roots(dd, *at, starts=np.asarray(full(z), float).T, stops=active)
            if res["valid"][0] and res["stops"][0] == active and abs(res["q1"][0]) <= RESIDUAL_TOL:
                return float(z[-1])
        if not bracket:
            return None
        last = [start, stops]  # each root starts from the one before, with its stops

        def q1(s):
            at = (s, dd.dpsi) if which == "psi1" else (self.psi1, s)
            res = self._roots(dd, *at, starts=np.atleast_2d(last[0]), stops=last[1])
            if not res["valid"][0]:
                raise SolveError(f"no Newton root at {which} = {s:g} on the way to q1 = 0", "Newton_Failed")
            last[:] = res["W"][0], res["stops"][0]
            return float(res["q1"][0])

        return float(brentq(q1, *bracket, xtol=1e-14, rtol=CRITICAL_RTOL))

    def _find_critical(self, dd: dv.DeviceDesign, which: str, xs, q1s, W, stops, guess: float, far: float):
        """The critical ``which`` (q1 = 0) from the roots (rows ``W`` with ``stops``) at ``xs`` with inner-seal flows
        ``q1s``: inside the sign change of q1 nearest ``guess`` (from its interpolated zero); without one, from the
        last root and ``guess``, then inside the first sign change of q1 followed beyond the last root towards
        ``far`` in steps of x WALK_FACTOR (or / WALK_FACTOR).  None: no critical there."""
        ok = np.flatnonzero(np.isfinite(q1s))
        x, q = xs[ok], q1s[ok]
        flips = np.flatnonzero(np.sign(q[:-1]) * np.sign(q[1:]) <= 0)
        if flips.size:
            i = flips[np.argmin(np.abs(x[flips] - guess))]
            zero = x[i] - q[i] * (x[i + 1] - x[i]) / (q[i + 1] - q[i]) if q[i + 1] != q[i] else x[i]
            return self._critical(dd, which, W[ok[i]].copy(), stops[ok[i]], zero, (x[i], x[i + 1]))
        start, at_stops = W[ok[-1]].copy(), stops[ok[-1]]
        found = self._critical(dd, which, start, at_stops, guess, None)
        x, q = x[-1], q[-1]
        step = WALK_FACTOR if far > x else 1 / WALK_FACTOR
        while found is None and ((x < far) if step > 1 else (x > far)):
            nxt = min(x * step, far) if step > 1 else max(x * step, far)
            res = self._roots(dd, *((nxt, dd.dpsi) if which == "psi1" else (self.psi1, nxt)),
                              starts=np.atleast_2d(start), stops=at_stops)
            if not res["valid"][0]:
                raise SolveError(f"no Newton root at {which} = {nxt:g} on the way to q1 = 0", "Newton_Failed")
            if np.sign(res["q1"][0]) != np.sign(q):
                found = self._critical(dd, which, start, at_stops, nxt, (x, nxt) if nxt > x else (nxt, x))
            start, at_stops, x, q = res["W"][0], res["stops"][0], nxt, res["q1"][0]
        return found

    def evaluate(self, values: dict) -> dict:
        """Operating point, criticals, characteristic and verdict for the settings ``values`` (path -> scene unit).

        Returns a dict with ``status`` "ok", "refused" (a setting the device's declarations refuse) or "no_statics"
        (no static solution at the operating point); ``message`` says why.  SI inside; a critical that has no value
        is None with ``*_status`` saying why."""
        from autobal.analysis.numerics import closed_form
        from autobal.analysis.studies.statics_study import verdict

        t0 = time.perf_counter()
        dev, dd, pt = self._setting(values)
        if pt is None:
            return dd
        sc, g, reg = dd.scales, dd.groups, dd.groups.regulator is not None
        out = {"status": "ok", "message": "", **self._operating_point(pt, dd), "has_regulator": reg,
               "p1": self.psi1 * sc["p_B"], "dp": (pt["psi_e"] - self.psi1) * sc["p_B"]}
        # the characteristic over the scene's discharge ratios, warm-started from the last one
        start = self._sweep if self._sweep is not None and self._sweep.shape[1] == len(self._last[1]) else None
        sw = self._continued(dd, self._roots(dd, self.grid, dd.dpsi, starts=start))
        self._sweep = sw["W"].copy()
        u = self._statics(dd)[0].system.index("u")
        stops = sw["stops"]
        out["sweep"] = {"p1": self.grid * sc["p_B"], "gap": sw["W"][:, u] * sc["z_B"],
                        "leak": sw["q"][:, self._statics(dd)[0].system.throttles.index("e")] * sc["Q_scale"],
                        "inner_seal_flow": sw["q1"] * sc["Q_scale"],
                        "saturated": [s is not None and "r_valve" in s for s in stops],
                        "contact": [s is not None and "r_contact" in s for s in stops],
                        "solved": [s is not None for s in stops]}
        # the criticals (q1 = 0), started as the study starts IPOPT: from the closed forms
        cf = closed_form.for_medium(g, self.psi1, dd.dpsi)
        psi1_kr, dpsi_kr = float(cf["psi1_kr"]), float(cf["dpsi_kr"])
        here = np.array([[pt[k] for k in self._statics(dd)[0].system.unknowns]])
        crit = {}
        for which, xs, q1s, W, at_stops, guess, far, name, unit, where in (
                ("psi1", self.grid, sw["q1"], sw["W"], stops, min(psi1_kr, self.psi1_max) if psi1_kr > 0 else
                 self.psi1, PSI1_MAX, "p1_kr", "no discharge ratio with q1 = 0 found", f"up to psi1 = {PSI1_MAX:g}"),
                ("dpsi", np.array([dd.dpsi]), np.array([pt["_flows"]["1"]]), here, [pt["_active"]],
                 dpsi_kr if dpsi_kr > 0 else dd.dpsi, DPSI_MIN if pt["_flows"]["1"] > 0 else DPSI_MAX, "dp_kr",
                 f"no margin with q1 = 0 at psi1 = {self.psi1:g}", f"between dpsi = {DPSI_MIN:g} and {DPSI_MAX:g}")):
            try:
                kr = self._find_critical(dd, which, xs, q1s, W, at_stops, guess, far)
                why = f"q1 keeps its sign {where}"
            except (SolveError, ValueError) as exc:
                kr, why = None, str(exc)
            crit |= {f"{which}_kr": kr, name: None if kr is None else kr * sc["p_B"]}
            if kr is None:
                crit[f"{which}_kr_status"] = f"{unit}: {why}"
        out["critical"] = crit
        out["margin_to_p1_kr"] = None if crit["p1_kr"] is None else crit["p1_kr"] - out["p1"]
        out["verdict"] = verdict(self.psi1, out["gap"], out["inner_seal_flow"], "r_contact" in pt["_active"],
                                 ("r_valve" in pt["_active"]) if reg else None, out["dp"], crit["dp_kr"],
                                 crit["psi1_kr"])
        # the sweep's checks, as the report's statics section words them
        first = {what: self.grid[flags.index(True)] for what, flags in (
            ("regulator saturated (valve on its stop)", out["sweep"]["saturated"]),
            ("face contact", out["sweep"]["contact"]),
            ("no Newton root (not drawn)", [not ok for ok in out["sweep"]["solved"]])) if any(flags)}
        out["sweep_checks"] = [f"{what} in the sweep from p1 = {_fmt(x * sc['p_B'] / 1e6, 4)} MPa (ψ1 = {_fmt(x, 4)})"
                               for what, x in first.items()]
        out["compute_ms"] = 1e3 * (time.perf_counter() - t0)
        return out


class SpinupExplorer(Settings):
    """The what-if computation of a spin-up scene (``analyses.spinup``): the current optimum's speed profile and the
    constant ramps re-simulated (the batch run's re-simulations, :func:`autobal.ocp.simulation.resimulate` and
    :func:`~autobal.ocp.simulation.baselines`, by the rotor's exact linear response; CVODES in :meth:`check`) for a
    changed rotor or drive; the optimum itself is found again only on request (:meth:`optimise`: the batch run's
    optimisation)."""

    def __init__(self, source: str | Path):
        super().__init__(source)
        sc = self.scene
        if getattr(sc, "rotor", None) is None or getattr(sc.analyses, "spinup", None) is None:
            raise ScenarioError(f"{sc.name}: {NEEDS}")
        self.params = parameters(sc.rotor, self.raw, "rotor") + [
            p for key in DRIVE_SETTINGS if (p := setting(sc.analyses.spinup, self.raw, f"analyses.spinup.{key}"))]
        # the current optimum's speed profile: (acceleration rad/s^2 and duration s of each interval, the settings
        # it was optimised for); in physical units, so that a changed rotor or drive re-simulates the same profile
        self.profile = None

    def problem(self, values: dict):
        """The spin-up problem (SpinupOcp) of the settings: the scene's rotor section and the drive's settings of
        ``analyses.spinup`` with them, by the analysis' own adapter."""
        from autobal.analyses import spinup

        scene = self.scene.model_copy(update={"rotor": self.section("rotor", values)})
        for path, p in self.by_path.items():
            if path.startswith("analyses.") and values[path] != p.value:
                scene = _with(scene, path, p.si(values[path]))
        return spinup.ocp(scene, scene.analyses.spinup)

    def optimise(self, values: dict) -> dict:
        """The batch run's optimisation (``analyses.spinup``) of the settings; keeps its profile as the current
        optimum.  Returns its peak (delta/e) and its time (s)."""
        from autobal.analyses import spinup

        t0 = time.perf_counter()
        scene = scenario.load(self.path, overrides=self.overrides(values))
        res = spinup.run(scene, scene.analyses.spinup)
        tr = res.optimum
        self.profile = (np.asarray(tr.alpha, float), np.diff(np.append(tr.t_u, tr.t[-1])), dict(values))
        return {"peak_over_e": res.peak_deflection_over_e, "seconds": time.perf_counter() - t0}

    def evaluate(self, values: dict, fast: bool = True) -> dict:
        """The current optimum's profile and the constant ramps re-simulated for the settings: peaks (delta/e and
        m), the critical speed (rad/s) with its API 684 margins (``api``:
        :func:`analysis.numerics.standards.margin_check`'s dict, as the spin-up study's ``rotor`` block), the drive's
        use; ``status`` "ok", "refused" or "no_optimum".  ``fast``: the re-simulations by the rotor's exact linear
        response (:func:`autobal.ocp.linear_response.resimulate`, the page's live path), else by CVODES at the batch
        run's tolerance (:func:`autobal.ocp.simulation.resimulate`, the cross-check); ``resimulation`` says which
        ran."""
        from autobal.analysis.studies.rotor_study import api_margins
        from autobal.ocp import linear_response
        from autobal.ocp.simulation import baselines, drive_use, resimulate

        t0 = time.perf_counter()
        try:
            ocp = self.problem(values)
        except (ValueError, ZeroDivisionError, AutobalError) as exc:
            return {"status": "refused", "message": str(exc)}
        P = ocp.params
        if fast:  # the exact linear response where the rotor has one (not critically damped), else CVODES
            try:
                linear_response.fixed_frame(), linear_response.modes(ocp)
            except ValueError:
                fast = False
        resim = linear_response.resimulate if fast else resimulate
        out = {"status": "ok", "message": "", "critical_speed": P.omega_cr, "eccentricity": P.e, "ramps": {},
               # API 684 (2005): AF and SM of the changed rotor from its service (final) speed, as the study's
               "api": api_margins(P, ocp.omega_final), "resimulation": "linear response" if fast else "CVODES"}
        for key, tr in baselines(ocp, resim=resim).items():
            out["ramps"][key] = {"label": tr.label, "peak_over_e": tr.peak_delta, "time_of_peak": tr.t_peak,
                                 "t": tr.t, "delta": tr.delta,
                                 "within_drive_limits": drive_use(ocp, tr)["within_drive_limits"]}
        if self.profile is None:
            return out | {"status": "no_optimum", "message": "the optimum is being found (autobal run's "
                                                             "optimisation)"}
        alpha, dt, at = self.profile
        tr = resim(ocp, alpha / ocp.alpha_max, dt * ocp.Om, "optimum")  # in the changed problem's scales
        out["optimum"] = {"peak_over_e": tr.peak_delta, "t": tr.t, "delta": tr.delta, "time_of_peak": tr.t_peak,
                          "omega": tr.omega, "within_drive_limits": drive_use(ocp, tr)["within_drive_limits"],
                          "optimised_for": self.overrides(at)}
        out["compute_ms"] = 1e3 * (time.perf_counter() - t0)
        return out


    # -- the cross-check on release
    def check(self, values: dict, answer: dict) -> str:
        """The re-simulations by CVODES at the batch run's tolerance (``evaluate(fast=False)``: what ``autobal run``
        does) against the live answer: '' when every peak agrees to :data:`SPINUP_CHECK_RTOL` and its time to
        :data:`SPINUP_CHECK_T`, else CVODES's numbers where they differ (then shown on the page)."""
        cv = self.evaluate(values, fast=False)
        if cv["status"] != answer.get("status"):
            return f"CVODES's re-simulation gives status {cv['status']} ({cv['message']}), the live path " \
                   f"{answer.get('status')}"
        if cv["status"] not in ("ok", "no_optimum"):
            return ""
        pairs = [(r["label"], r, answer["ramps"].get(k)) for k, r in cv["ramps"].items()]
        if "optimum" in cv:
            pairs.append(("current optimum's profile", cv["optimum"], answer.get("optimum")))
        off = [f"{label}: peak δ/e {r['peak_over_e']:.10g} at {r['time_of_peak']:.6g} s" for label, r, live in pairs
               if live is None or abs(r["peak_over_e"] / live["peak_over_e"] - 1) > SPINUP_CHECK_RTOL
               or abs(r["time_of_peak"] - live["time_of_peak"]) > SPINUP_CHECK_T]
        return "CVODES's re-simulation differs: " + "; ".join(off) if off else ""


def _exact_statics(ans: dict) -> str:
    """The statics page's numbers at full precision (JSON, SI), for the browser test's comparison."""
    import json

    return json.dumps({k: ans[k] for k in ("gap", "leak", "dp", "margin_to_p1_kr")} | {
        k: ans["critical"][k] for k in ("p1_kr", "dp_kr")})


def _exact_spinup(ans: dict, current: dict) -> str:
    """The spin-up page's numbers at full precision (JSON, SI; ``optimum_current``: the optimum's profile was
    optimised for the ``current`` settings), for the browser test's comparison."""
    import json

    opt = ans.get("optimum")
    return json.dumps({"critical_speed": ans["critical_speed"], "eccentricity": ans["eccentricity"],
                       "api": ans["api"], "ramps": {k: r["peak_over_e"] for k, r in ans["ramps"].items()},
                       "optimum": None if opt is None else opt["peak_over_e"],
                       "optimum_current": opt is not None and opt["optimised_for"] == current})


def _exact(ans: dict) -> str:
    """The shown numbers at full precision (JSON, SI), for the browser test's comparison."""
    import json

    keys = ("gap", "leak", "decay_rate", "min_damping_ratio", "amplitude_at_omega0", "static_amplitude")
    return json.dumps({k: float(ans[k]) for k in keys} | {"peaks": ans["peaks"]})


# ---- the page ----

#: the page: the sliders on the left (scrolling), the answer on the right; each root is laid out on its own
PAGE_HTML = """{% extends base %}
{% block contents %}
<div style="display:flex;gap:16px;align-items:flex-start">
  <div style="width:370px;height:96vh;overflow-y:auto;flex:none">{{ embed(roots.controls) }}</div>
  <div>{{ embed(roots.head) }}{{ embed(roots.numbers) }}{{ embed(roots.plots) }}</div>
</div>
{% endblock %}"""


CHAMBERS = {"psi2": "p2, disc chamber", "psi3": "p3, cavity", "psi_e": "p_e, barrier chamber",
            "psi_cam": "p_cam, valve chamber"}


def _fmt(v: float, digits: int = 6) -> str:
    return "—" if v is None or not np.isfinite(v) else f"{v:.{digits}g}"


def _sliders(explorer: Settings) -> dict:
    """One Bokeh slider per parameter, in the scene's unit and within its bounds: path -> Slider."""
    from bokeh.models import CustomJSTickFormatter, Slider

    shown = CustomJSTickFormatter(code="return String(Number(tick.toPrecision(6)))")  # 6 digits, any scale
    return {p.path: Slider(title=p.label, start=p.start, end=p.end, value=p.value,
                           step=(p.end - p.start) / SLIDER_STEPS, format=shown, width=330, name=p.path)
            for p in explorer.params}


def _record_buttons(doc, explorer: Settings, values: dict, out: Path):
    """"save scene" (the settings as a YAML scene with units) and "report" (``autobal.run`` of it, in a thread,
    writing report.html): a row of both and the line that says what they wrote."""
    from bokeh.layouts import row
    from bokeh.models import Button, Div

    save_btn, report_btn = Button(label="save scene", name="save"), Button(label="report", name="report")
    saved = Div(text="", name="saved")

    def on_save():
        path = out / f"{explorer.scene.name}_explored.yaml"
        try:
            out.mkdir(parents=True, exist_ok=True)
            explorer.save(values, path)
        except OSError as exc:
            saved.text = f"not saved: {html.escape(str(exc))}"
            return
        saved.text = f"saved <code id='saved_path'>{path}</code>"

    def on_report():
        vals = dict(values)
        try:
            out.mkdir(parents=True, exist_ok=True)
            path = explorer.save(vals, out / f"{explorer.scene.name}_explored.yaml")
        except OSError as exc:
            saved.text = f"no report: the scene cannot be saved: {html.escape(str(exc))}"
            return
        report_btn.disabled = True
        saved.text = "running the report (autobal.run) …"

        def work():
            import autobal

            try:
                folder = out / f"{explorer.scene.name}_explored"
                autobal.run(autobal.load(path), out=folder)
                msg = f"report written: <code id='report_path'>{folder / 'report.html'}</code>"
            except Exception as exc:  # noqa: BLE001
                msg = f"report failed: {html.escape(f'{type(exc).__name__}: {exc}')}"

            def done():
                saved.text = msg
                report_btn.disabled = False
            doc.add_next_tick_callback(done)
        threading.Thread(target=work, daemon=True).start()

    save_btn.on_click(on_save)
    report_btn.on_click(on_report)
    return row(save_btn, report_btn, saved)


_SEQ = re.compile(r"<span id='seq'[^>]*>\d+</span>$")


def _latest_wins(doc, evaluate, show, verdict):
    """``request(values, moved)``: compute the settings on the server's next tick and show them, the latest
    winning (settings that arrive while one is computed are coalesced); each property changed by an update is one
    message to the browser (``doc.hold``: a property set twice is sent once, in the order first set); the updates
    are counted in a hidden ``#seq`` at the end of the ``verdict`` Div, which ``show`` sets last (the browser test
    times them: the page is updated when it changes); the server survives every setting."""
    state = {"pending": None, "busy": False, "seq": 0}

    def compute():
        while state["pending"] is not None:
            vals, moved = state["pending"]
            state["pending"] = None
            try:
                ans = evaluate(vals)
            except Exception as exc:  # noqa: BLE001 (the server survives every setting)
                ans = {"status": "failed", "message": f"{type(exc).__name__}: {exc}"}
            doc.hold("combine")  # one message to the browser per update, not one per property
            try:
                show(ans, moved)
                state["seq"] += 1  # with the verdict: one message, the update's last
                verdict.text = _SEQ.sub("", verdict.text) + f"<span id='seq' hidden>{state['seq']}</span>"
            finally:
                doc.unhold()
        state["busy"] = False

    def request(values: dict, moved: str | None):
        state["pending"] = (dict(values), moved)
        if not state["busy"]:
            state["busy"] = True
            doc.add_next_tick_callback(compute)

    return request


def _verdict_html(words: str, colour: str, status: str) -> str:
    """The verdict line (``words`` in ``colour``, bold) and the status line under it: one Div's text, so that an
    update changes one property."""
    return (f"<div style='color:{colour};font-size:16px;font-weight:bold'><span id='verdict_text'>"
            f"{html.escape(words)}</span></div><div><span id='status_text'>{html.escape(status)}</span></div>")


def _say(verdict, ans: dict, moved: str | None, words: str | None = None, ok: bool = False) -> None:
    """The verdict and status lines of a device page: ``words`` (green when ``ok``, else red) for a computed
    setting, or the failed setting's status and message (then the numbers shown are the last good answer)."""
    if words is None:
        words = ans["status"].replace("_", " ").upper() + ": " + ans["message"] + (
            f" (after changing {moved.removeprefix('device.')})" if moved else "")
        status = "the numbers in grey are the last good answer, not the current setting"
    else:
        status = f"current (computed in {ans['compute_ms']:.1f} ms)"
    verdict.text = _verdict_html(words, "green" if ok else "red", status)


def _browser_only(doc, sliders: dict, *figs) -> None:
    """What the server does not use stays in the browser: the plots' automatic ranges (BokehJS would send each range
    it computes after an update back to the server) and the sliders' ``value_throttled`` (sent beside ``value`` at
    every key press): a message and its reply each, every change."""
    from bokeh.models import CustomJS, DataRange1d

    ranges = [r for f in figs for r in (f.x_range, f.y_range) if isinstance(r, DataRange1d)]
    doc.js_on_event("document_ready", CustomJS(args={"ranges": ranges, "sliders": list(sliders.values())}, code=(
        "for (const r of ranges) Object.defineProperty(r, 'is_syncable', {get: () => false});\n"
        "for (const s of sliders) Object.defineProperty(s.properties.value_throttled, 'syncable', "
        "{get: () => false});")))


def _connect(doc, explorer: Settings, sliders: dict, values: dict, state: dict, check, request,
             agrees: str = "the scene's checks pass and IPOPT agrees with the operating point", moved=lambda p: p):
    """A page's sliders: each change computed (``request``, the slider named by ``moved(path)``), and the
    cross-check (``explorer.check``: IPOPT's on a device page, CVODES's on a spin-up page; in a thread) once the
    sliders have rested :data:`CHECK_AFTER_S`, said in the ``check`` Div (``agrees`` when it agrees);
    ``state["good"]``: the last good answer.  Returns ``rested()``, which (re)starts the wait for the check."""

    def on_change(path):
        def cb(attr, old, new):
            values[path] = float(new)
            check.text = ""
            request(values, moved(path))
            rested()
        return cb

    def run_check():
        state["timer"] = None
        vals, ans = dict(values), state["good"]

        def work():
            try:
                text = explorer.check(vals, ans or {})
            except Exception as exc:  # noqa: BLE001 (the page says what failed; the server goes on)
                text = f"the cross-check failed: {type(exc).__name__}: {exc}"

            def done():
                if vals == values:  # still the setting checked
                    check.text = (f"<span id='crosscheck' style='color:#b35900'>cross-check: {html.escape(text)}"
                                  "</span>" if text else f"<span id='crosscheck'>cross-check: {agrees}</span>")
            doc.add_next_tick_callback(done)
        threading.Thread(target=work, daemon=True).start()

    def rested():  # IPOPT's cross-check once the sliders rest for CHECK_AFTER_S
        if state.get("timer") is not None:
            doc.remove_timeout_callback(state["timer"])
        state["timer"] = doc.add_timeout_callback(run_check, int(CHECK_AFTER_S * 1000))

    for path, slider in sliders.items():
        slider.on_change("value", on_change(path))
    return rested


def _device_page(explorer: DeviceSettings, out: Path, build, verdict_height: int, numbers_height: int):
    """The Bokeh document builder of a device page (one per browser session): the sliders, the verdict line (and the
    status line under it), the cross-check line, "save scene" and "report", the ``numbers`` Div and the page's
    plots, each change computed (latest wins) and cross-checked once the sliders rest.  ``build(doc, values, state,
    sliders, verdict, numbers)`` makes the page's own plots and returns (``show(ans, moved)``, the plots' root, the
    Divs under the verdict line)."""
    from bokeh.layouts import column
    from bokeh.models import Div
    from jinja2 import Template

    page = Template(PAGE_HTML)

    def modify(doc):
        values = explorer.defaults()
        state = {"good": None}
        sliders = _sliders(explorer)
        # fixed sizes: a new text re-renders its Div only, not the page's layout
        verdict = Div(text="", name="verdict", width=1100, height=verdict_height)  # and the status line under it
        numbers = Div(text="", name="numbers", width=1100, height=numbers_height)
        check = Div(text="", name="check", width=1100, height=20)
        record = _record_buttons(doc, explorer, values, out)
        show, plots, under = build(doc, values, state, sliders, verdict, numbers)
        request = _latest_wins(doc, explorer.evaluate, show, verdict)
        _connect(doc, explorer, sliders, values, state, check, request)
        request(values, None)
        head = Div(text=f"<h2>{html.escape(explorer.scene.title)}</h2><p title='{html.escape(str(explorer.path))}'>"
                            f"scene {html.escape(explorer.source)}</p>")
        # separate roots placed by the template: a changed text lays out its own root, not the 40 sliders
        doc.add_root(column(head, verdict, *under, check, record, name="head"))
        doc.add_root(column(*sliders.values(), name="controls"))
        doc.add_root(numbers)
        doc.add_root(plots)
        doc.template = page
        doc.title = f"autobal explore: {explorer.scene.name}"

    return modify


def make_document(explorer: DeviceExplorer, out: Path):
    """The Bokeh document builder of a device-dynamics scene's page: operating point, poles, margin, AFC."""
    from bokeh.layouts import row
    from bokeh.models import ColumnDataSource
    from bokeh.plotting import figure

    def build(doc, values, state, sliders, verdict, numbers):
        afc_src = ColumnDataSource({"hz": [], "amp": []})
        pole_src = ColumnDataSource({"abs_re": [], "hz": [], "colour": []})
        afc = figure(title="AFC of the face gap (physical forcing)", x_axis_label="frequency, Hz",
                     y_axis_label="amplitude, µm", x_axis_type="log", y_axis_type="log", width=560, height=300,
                     name="afc", toolbar_location=None,
                     x_range=(explorer.omega_range[0] / (2 * np.pi), explorer.omega_range[1] / (2 * np.pi)))
        afc_line = afc.line("hz", "amp", source=afc_src, line_width=2)
        pmap = figure(title="poles: decay rate −Re λ against frequency Im λ / 2π", x_axis_label="|Re λ|, 1/s",
                      y_axis_label="Im λ / 2π, Hz", x_axis_type="log", width=560, height=300, name="poles",
                      toolbar_location=None)
        pole_dots = pmap.scatter("abs_re", "hz", source=pole_src, size=9, marker="x", line_width=2, color="colour")
        _browser_only(doc, sliders, afc, pmap)

        def show(ans: dict, moved: str | None):
            good = ans.get("status") == "ok"
            grey = "#999" if not good else "black"
            if good:
                state["good"] = ans
            last = ans if good else state["good"]
            if "gap" in ans or (last is not None):
                src = ans if "gap" in ans else last
                pr = "".join(f"<tr><td>{CHAMBERS[k]}</td><td id='p_{k}'>{_fmt(v / 1e6)}</td>"
                             f"<td>MPa</td></tr>" for k, v in src["pressures"].items())
                op = (f"<table style='color:{'black' if 'gap' in ans else '#999'}'><tr><th colspan=3>operating point"
                      f"</th></tr><tr><td>face gap</td><td id='gap'>{_fmt(src['gap'] * 1e6)}</td><td>µm</td></tr>{pr}"
                      f"<tr><td>barrier leak Q_e</td><td id='leak'>{_fmt(src['leak'] * 1e3)}</td><td>L/s</td></tr>"
                      f"<tr><td>inner seal flow Q_1</td><td>{_fmt(src['inner_seal_flow'] * 1e3)}</td><td>L/s</td>"
                      f"</tr></table>")
            else:
                op = ""
            if last is not None and "poles" in last:
                pk = "".join(f"<tr><td>resonance {i + 1}</td><td id='peak{i}_hz'>{_fmt(q['omega'] / (2 * np.pi))}"
                             f"</td><td>Hz</td><td id='peak{i}_um'>{_fmt(q['amplitude'] * 1e6)}</td><td>µm</td></tr>"
                             for i, q in enumerate(last["peaks"]))
                dyn = (f"<table style='color:{grey}'><tr><th colspan=5>dynamics (energy-consistent model)</th></tr>"
                       f"<tr><td>decay rate −max Re λ</td><td id='decay'>{_fmt(last['decay_rate'])}</td>"
                       f"<td>1/s</td></tr><tr><td>min damping ratio</td><td id='zeta'>"
                       f"{_fmt(last['min_damping_ratio'])}</td><td></td></tr>{pk}"
                       f"<tr><td>amplitude at ω0 ({_fmt(last['omega0'] / (2 * np.pi), 4)} Hz)</td>"
                       f"<td id='amp0'>{_fmt(last['amplitude_at_omega0'] * 1e6)}</td><td>µm</td></tr>"
                       f"<tr><td>static amplitude</td><td id='amp_static'>{_fmt(last['static_amplitude'] * 1e6)}</td>"
                       f"<td>µm</td></tr></table>")
                re, im, zeta = last["poles"]["real"], last["poles"]["imag"], last["damping_ratio"]
                rows = "".join(f"<tr><td>{_fmt(-a)}</td><td>{_fmt(b / (2 * np.pi))}</td><td>{_fmt(z, 4)}</td></tr>"
                               for a, b, z in zip(re, im, zeta, strict=True) if b >= 0)
                dyn += (f"<table id='pole_table' style='color:{grey}'><tr><th>decay rate −Re λ, 1/s</th>"
                        f"<th>frequency Im λ / 2π, Hz</th><th>damping ratio ζ</th></tr>{rows}</table>")
                if good:
                    re, im = last["poles"]["real"], last["poles"]["imag"]
                    # a few numbers: lists, inline in the patch's JSON (an array is a binary frame pair of its own)
                    pole_src.data = {"abs_re": np.abs(re).tolist(), "hz": (im / (2 * np.pi)).tolist(),
                                     "colour": np.where(re < 0, "#1f77b4", "#d62728").tolist()}
                    afc_src.data = {"hz": last["omega"] / (2 * np.pi), "amp": last["amplitude"] * 1e6}
            else:
                dyn = ""
            afc_line.glyph.line_color = "#1f77b4" if good else "#bbb"
            pole_dots.glyph.line_alpha = 1.0 if good else 0.25
            exact = _exact(ans) if good else "{}"
            numbers.text = (f"<div style='display:flex;gap:24px'>{op}{dyn}</div>"
                            f"<span id='exact' style='display:none'>{exact}</span>")
            if good:
                alpha = ans["required_decay"]
                words = (f"stable: disturbances decay at {_fmt(ans['decay_rate'], 4)} 1/s" if ans["stable"] else
                         f"UNSTABLE: disturbances grow at {_fmt(-ans['decay_rate'], 4)} 1/s")
                if alpha > 0:
                    words += f" (required {_fmt(alpha, 4)} 1/s)"
                if not ans["meets_requirement"] and moved:
                    words += f"; margin crossed by {moved.removeprefix('device.')}"
                _say(verdict, ans, moved, words, ans["meets_requirement"])
            else:
                _say(verdict, ans, moved)

        return show, row(afc, pmap, name="plots"), []

    return _device_page(explorer, out, build, verdict_height=46, numbers_height=190)


def _rows(rows) -> str:
    """Table rows (label, id, value shown, unit)."""
    return "".join(f"<tr><td>{label}</td><td id='{key}'>{shown}</td><td>{unit}</td></tr>"
                   for label, key, shown, unit in rows)


def make_statics_document(explorer: StaticsExplorer, out: Path):
    """The Bokeh document builder of a device-statics scene's page: operating point, critical discharge pressure
    and margins, the static characteristic (face gap and flows against the discharge pressure), the verdict."""
    from bokeh.layouts import row
    from bokeh.models import ColumnDataSource, Div, Span
    from bokeh.plotting import figure

    def build(doc, values, state, sliders, verdict, numbers):
        sweep_words = Div(text="", name="sweep_checks", width=1100, height=20)
        curve = ColumnDataSource({"p1": [], "gap": [], "leak": [], "q1": [], "colour": []})
        here = ColumnDataSource({"p1": [], "gap": [], "leak": [], "q1": []})
        figs = {}
        for key, title, label in (("gap", "face gap against discharge pressure", "face gap z, µm"),
                                  ("flows", "barrier leak Q_e and inner-seal flow Q_1", "flow, L/s")):
            figs[key] = figure(title=title, x_axis_label="discharge pressure p1, MPa", y_axis_label=label,
                               width=560, height=320, name=key, toolbar_location=None)
        lines = [figs["gap"].line("p1", "gap", source=curve, line_width=2),
                 figs["flows"].line("p1", "leak", source=curve, line_width=2, legend_label="barrier leak Q_e"),
                 figs["flows"].line("p1", "q1", source=curve, line_width=2, color="#2ca02c",
                                    legend_label="inner-seal flow Q_1")]
        figs["gap"].scatter("p1", "gap", source=curve, color="colour", size=5)
        figs["flows"].scatter("p1", "leak", source=curve, color="colour", size=5)
        for key, y in (("gap", "gap"), ("flows", "leak"), ("flows", "q1")):
            figs[key].scatter("p1", y, source=here, marker="diamond", size=13, color="black")
        figs["flows"].legend.location = "bottom_left"
        _browser_only(doc, sliders, *figs.values())
        crit = {k: Span(location=math.nan, dimension="height", line_color="#d62728", line_dash="dashed",
                        line_width=1.5) for k in figs}
        for k, f in figs.items():
            f.add_layout(crit[k])

        def show(ans: dict, moved: str | None):
            good = ans.get("status") == "ok"
            if good:
                state["good"] = ans
            last = ans if good else state["good"]
            if last is not None:
                c, mpa = last["critical"], 1e-6
                op = [("discharge pressure p1", "p1", _fmt(last["p1"] * mpa), "MPa"),
                      ("face gap z0", "gap", _fmt(last["gap"] * 1e6), "µm")]
                op += [(CHAMBERS[k], f"p_{k}", _fmt(v * mpa), "MPa") for k, v in last["pressures"].items()]
                op += [("barrier leak Q_e", "leak", _fmt(last["leak"] * 1e3), "L/s"),
                       ("inner-seal flow Q_1", "inner_seal_flow", _fmt(last["inner_seal_flow"] * 1e3), "L/s")]
                if last["has_regulator"]:
                    op.append(("valve opening x0", "valve", _fmt(last["valve_opening"] * 1e3), "mm"))
                kr = [("critical discharge pressure p1_kr (Q_1 = 0)", "p1_kr",
                       _fmt(c["p1_kr"] * mpa) if c["p1_kr"] is not None else "none", "MPa"),
                      ("margin to it p1_kr − p1", "margin_p1_kr", _fmt(last["margin_to_p1_kr"] * mpa)
                       if c["p1_kr"] is not None else "—", "MPa"),
                      ("operating barrier margin Δp = p_e − p1", "dp", _fmt(last["dp"] * mpa), "MPa"),
                      ("critical barrier margin Δp_kr (Q_1 = 0)", "dp_kr",
                       _fmt(c["dp_kr"] * mpa) if c["dp_kr"] is not None else "none", "MPa")]
                why = " ".join(html.escape(c[k]) for k in ("psi1_kr_status", "dpsi_kr_status") if k in c)
                grey = "black" if good else "#999"
                numbers.text = (f"<div style='display:flex;gap:24px;align-items:flex-start;color:{grey}'><table>"
                                f"<tr><th colspan=3>operating point</th></tr>{_rows(op)}</table><table><tr><th "
                                f"colspan=3>criticals (the inner-seal flow reverses)</th></tr>{_rows(kr)}</table>"
                                f"</div><p>{why}</p><span id='exact' style='display:none'>{_exact_statics(last)}</span>"
                                )
                sw = last["sweep"]
                curve.data = {"p1": sw["p1"] * mpa, "gap": sw["gap"] * 1e6, "leak": sw["leak"] * 1e3,
                              "q1": sw["inner_seal_flow"] * 1e3,
                              "colour": ["#d62728" if ct else "#ff7f0e" if sat else "#1f77b4"
                                         for sat, ct in zip(sw["saturated"], sw["contact"], strict=True)]}
                here.data = {"p1": [last["p1"] * mpa], "gap": [last["gap"] * 1e6], "leak": [last["leak"] * 1e3],
                             "q1": [last["inner_seal_flow"] * 1e3]}
                for span in crit.values():
                    span.location = c["p1_kr"] * mpa if c["p1_kr"] is not None else math.nan
                for line in lines:
                    line.glyph.line_alpha = 1.0 if good else 0.3
            if good:
                ok, words = ans["verdict"]
                if not ok and moved:
                    words += f" (after changing {moved.removeprefix('device.')})"
                sweep_words.text = ("<span id='sweep_text' style='color:#b35900'>" + html.escape(
                    "; ".join(ans["sweep_checks"])) + " (orange: valve on its stop, red: face contact, gap 0)</span>"
                                    if ans["sweep_checks"] else "<span id='sweep_text'></span>")
                _say(verdict, ans, moved, words, ok)
            else:
                _say(verdict, ans, moved)

        return show, row(figs["gap"], figs["flows"], name="plots"), [sweep_words]

    return _device_page(explorer, out, build, verdict_height=68, numbers_height=230)


RAMP_COLOURS = {"constant_ramp": "#7f7f7f", "max_acceleration_ramp": "#ff7f0e", "feasible_ramp": "#2ca02c"}


def make_spinup_document(explorer: SpinupExplorer, out: Path):
    """The Bokeh document builder of a spin-up scene's page: the deflection of the current optimum's profile and of
    the ramps re-simulated for the settings, and "re-optimise" (the batch optimisation, in a thread)."""
    from bokeh.layouts import column, row
    from bokeh.models import Button, ColumnDataSource, Div
    from bokeh.plotting import figure
    from jinja2 import Template

    page = Template(PAGE_HTML)
    lock = threading.Lock()  # one optimisation at a time, whatever the sessions

    def modify(doc):
        values = explorer.defaults()
        state = {"started": None, "good": None}
        sliders = _sliders(explorer)
        verdict = Div(text="", width=1100, height=46)  # and the status line under it
        check = Div(text="", name="check", width=1100, height=20)
        numbers = Div(text="", name="numbers", width=1100, height=150)
        fig = figure(title="deflection δ/e of the rotor", x_axis_label="time, s", y_axis_label="δ/e", width=900,
                     height=360, name="plots", toolbar_location=None)
        sources = {k: ColumnDataSource({"t": [], "d": []}, name=f"{k}_profile") for k in ("optimum", *RAMP_COLOURS)}
        lines = {"optimum": fig.line("t", "d", source=sources["optimum"], line_width=2.5, color="#1f77b4",
                                     legend_label="current optimum's profile")}
        for k, c in RAMP_COLOURS.items():
            lines[k] = fig.line("t", "d", source=sources[k], line_width=1.5, color=c, legend_label=k.replace("_", " "))
        labels = {k: next(i for i in fig.legend.items if lines[k] in i.renderers) for k in RAMP_COLOURS}
        reopt = Button(label="re-optimise", name="reoptimise", button_type="primary")
        _browser_only(doc, sliders, fig)

        def show(ans: dict, moved: str | None):
            good = ans["status"] in ("ok", "no_optimum")
            rows = []
            if good:
                state["good"] = ans
                for k, r in ans["ramps"].items():
                    sources[k].data = {"t": r["t"], "d": r["delta"]}
                    rows.append((r["label"], r["peak_over_e"], r["within_drive_limits"]))
                for k, item in labels.items():  # a ramp this setting has not: neither its curve nor its label
                    lines[k].visible = item.visible = k in ans["ramps"]
            opt = ans.get("optimum")
            if opt is not None:
                sources["optimum"].data = {"t": opt["t"], "d": opt["delta"]}
                rows.insert(0, ("current optimum's profile", opt["peak_over_e"], opt["within_drive_limits"]))
            e = ans.get("eccentricity", math.nan)
            table = "".join(f"<tr><td>{html.escape(label)}</td><td id='peak_{i}'>{_fmt(pk)}</td>"
                            f"<td><span id='peak_um_{i}'>{_fmt(pk * e * 1e6)}</span> µm</td>"
                            f"<td>{'yes' if ok else 'NO' if ok is False else '—'}</td>"
                            f"</tr>" for i, (label, pk, ok) in enumerate(rows))
            if good:
                crit, api = ans["critical_speed"], ans["api"]
                kept = api["separation_margin_ok"]
                af = "—" if api["amplification_factor"] is None else _fmt(api["amplification_factor"], 4)
                numbers.text = (f"<p>critical speed <span id='critical'>{_fmt(crit * 30 / np.pi)}</span> rpm "
                                f"({_fmt(crit)} rad/s); API 684: AF <span id='af'>{af}</span>, SM <span id='sm'>"
                                f"{_fmt(api['separation_margin_pct'], 4)}</span> % from the service speed, required "
                                f"<span id='sm_req'>{_fmt(api['required_separation_margin_pct'], 3)}</span> %: "
                                f"<b id='sm_ok' style='color:{'green' if kept else 'red'}'>"
                                f"{'kept' if kept else 'NOT kept' if kept is False else '—'}</b></p>"
                                f"<table><tr><th>profile</th><th>peak δ/e</th><th>peak δ</th>"
                                f"<th>within the drive's limits</th></tr>{table}</table><span id='exact' "
                                f"style='display:none'>{html.escape(_exact_spinup(ans, explorer.overrides(values)))}"
                                "</span>")
            feasible = [pk for label, pk, ok in rows[1:] if ok is not False]
            if opt is not None and good:
                best = min(feasible) if feasible else math.inf
                ok = opt["peak_over_e"] <= best and opt["within_drive_limits"] is not False
                words = (f"the optimum's profile: peak δ/e {_fmt(opt['peak_over_e'], 5)}, "
                         f"{'below' if ok else 'NOT below'} the best ramp the drive can run ({_fmt(best, 5)})")
                if not ok and moved:
                    words += f"; crossed by {moved} (re-optimise)"
                if opt["optimised_for"] != explorer.overrides(values):
                    words += " — profile optimised for other settings"
                how = "" if ans.get("resimulation") != "CVODES" else \
                    " by CVODES: the rotor is near critical damping, without the exact linear response"
                verdict.text = _verdict_html(words, "green" if ok else "red",
                                             f"current (computed in {ans['compute_ms']:.0f} ms{how})")
            else:
                verdict.text = _verdict_html(ans["status"].upper() + ": " + ans["message"], "#555" if good else "red",
                                             "current ramps; " + ("the optimum is being found" if good else
                                                                  "the curves in the plot are the last good answer"))

        request = _latest_wins(doc, explorer.evaluate, show, verdict)
        rested = _connect(doc, explorer, sliders, values, state, check, request,
                          "CVODES's re-simulation (autobal run's) agrees with the live response",
                          lambda path: path.removeprefix("rotor."))

        def tick():
            if state["started"] is not None:
                reopt.label = f"optimising … {time.perf_counter() - state['started']:.0f} s"

        def optimise():
            vals = dict(values)
            reopt.disabled, reopt.label = True, "optimising … 0 s"
            optimised.text = "<span id='optimising'>autobal run's optimisation of the current settings</span>"
            state["started"] = time.perf_counter()

            def work():
                with lock:
                    try:
                        res = explorer.optimise(vals)
                        msg = f"optimised in {res['seconds']:.1f} s"
                    except Exception as exc:  # noqa: BLE001
                        msg = f"optimisation failed: {type(exc).__name__}: {exc}"

                def done():
                    state["started"] = None
                    reopt.disabled, reopt.label = False, "re-optimise"
                    optimised.text = f"<span id='optimised'>{html.escape(msg)}</span>"
                    request(values, None)
                    check.text = ""  # CVODES checks the new optimum's profile once the page rests
                    rested()
                doc.add_next_tick_callback(done)
            threading.Thread(target=work, daemon=True).start()

        optimised = Div(text="", width=400)
        reopt.on_click(optimise)
        doc.add_periodic_callback(tick, 500)
        record = _record_buttons(doc, explorer, values, out)
        head = Div(text=f"<h2>{html.escape(explorer.scene.title)}</h2><p title='{html.escape(str(explorer.path))}'>"
                            f"scene {html.escape(explorer.source)}</p>")
        doc.add_root(column(head, verdict, check, row(reopt, optimised), record, name="head"))
        doc.add_root(column(*sliders.values(), name="controls"))
        doc.add_root(numbers)
        doc.add_root(fig)
        doc.template = page
        doc.title = f"autobal explore: {explorer.scene.name}"
        request(values, None)
        if explorer.profile is None:
            optimise()

    return modify


def serve(source: str | Path, port: int = 0, browser: bool = True, out: str | Path = "out", ready=None) -> None:
    """Serve the page of ``source`` on 127.0.0.1:``port`` (0: a free port) until interrupted; prints its URL.

    ``ready``: called with the URL once the server listens (tests)."""
    import os

    os.environ.setdefault("BOKEH_RESOURCES", "server")  # BokehJS from this server, never a CDN
    from bokeh.application import Application
    from bokeh.application.handlers import FunctionHandler
    from bokeh.server.server import Server
    from bokeh.server.views.ws import WSHandler

    scene = scenario.load(source)
    if getattr(scene, "device", None) is None and getattr(scene, "rotor", None) is not None:
        explorer, builder = SpinupExplorer(source), make_spinup_document
    elif getattr(scene, "device", None) is not None and scene.device.dynamics is None and getattr(
            scene.analyses, "statics", None) is not None:
        explorer, builder = StaticsExplorer(source), make_statics_document
    else:
        explorer, builder = DeviceExplorer(source), make_document
    if port == 0:  # a free port, known before the server starts (the websocket's allowed origin names it)
        with socket.socket() as s:
            s.bind((HOST, 0))
            port = s.getsockname()[1]
    app = Application(FunctionHandler(builder(explorer, Path(out).resolve())))
    server = Server({"/": app}, address=HOST, port=port, allow_websocket_origin=[f"{HOST}:{port}"])

    class NoDelayWS(WSHandler):  # small messages each way: no Nagle delay on the websocket
        def open(self):
            self.set_nodelay(True)
            return super().open()

    for rule in server._tornado.wildcard_router.rules:  # Bokeh's router: its websocket handler, without Nagle
        if rule.target is WSHandler:
            rule.target = NoDelayWS
    server.start()
    url = f"http://{HOST}:{server.port}/"
    print(f"autobal explore: {url}  (Ctrl-C to stop)", flush=True)
    if ready is not None:
        ready(url, server)
    if browser:
        import webbrowser

        server.io_loop.add_callback(webbrowser.open, url)
    server.io_loop.start()


def command(args) -> int:
    """``autobal explore SCENE [--port N] [--no-browser]``: serve the page until interrupted (exit 130)."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise ScenarioError("autobal explore needs Bokeh: pip install 'autobal[explore]'") from None
    if not 0 <= args.port <= 65535:
        raise ScenarioError(f"--port {args.port}: a port number is 0 to 65535 (0: a free one)")
    serve(args.scenario, port=args.port, browser=not args.no_browser)
    return 0
