"""Exact linear models at the static operating point, as python-control StateSpace objects.

``exact(model)``: CasADi Jacobians of the nonlinear model (models/dynamics.py) at its equilibrium
(the IPOPT static solution): dx/dt = A dx + B [dpsi1, dtau]... ordered as the hand model's inputs
(dtau, dpsi1).  ``hand(constants)``: the source's descriptor model (2.43)/(2.101),
E dX/dt = A X + G w with E nonsingular, converted to a StateSpace by solving with E.
``operator(model)``: the Jacobians of the model's implicit rows with respect to q, dq/dt and
d2q/dt2 in the layout of (2.101), from which the constants K1..K13, T1..T9 are read off
(analysis/hand_linear.from_operator).

Outputs of every LinearModel: all states; ``u_out`` is the index of the face gap du.  Inputs are
(dtau, dpsi1); the AFC forcing combines them as dtau = dpsi1 (appendix) or b dpsi1 (physical).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import control
import numpy as np

from autobal.analysis.numerics.hand_linear import (
    K_NAMES,
    OTHER,
    T_NAMES,
    Constants,
    constants,
    from_operator,
    program_point,
)
from autobal.analysis.numerics.statics import StaticsSolver
from autobal.errors import SolveError
from autobal.models.device import DeviceParams, design
from autobal.models.dynamics import DynamicModel, build

INPUTS = ["tau", "psi1"]


@dataclass
class LinearModel:
    """A linear model dx/dt = A x + B [dtau, dpsi1], y = x, with what the analyses need."""

    label: str
    A: np.ndarray
    B: np.ndarray
    states: list[str]
    b: float  # tau = b psi1 (physical forcing)
    z_B: float
    u_out: int = 0
    info: dict = field(default_factory=dict)

    @property
    def sys(self) -> control.StateSpace:
        n = len(self.states)
        return control.ss(self.A, self.B, np.eye(n), np.zeros((n, 2)), inputs=INPUTS, outputs=self.states,
                          states=self.states, name=self.label)

    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.A)

    def forcing(self, convention: str = "appendix") -> np.ndarray:
        """Input vector per unit dpsi1: dtau = dpsi1 (App. A/B) or dtau = b dpsi1 (physical)."""
        return self.B @ np.array([1.0 if convention == "appendix" else self.b, 1.0])

    def response(self, omega, convention: str = "appendix", output: int | None = None) -> np.ndarray:
        """Complex response of one output (default du) per unit dpsi1 at each omega (rad/s)."""
        j = self.u_out if output is None else output
        bvec = self.forcing(convention)
        n = len(self.states)
        om = np.atleast_1d(np.asarray(omega, float))
        M = 1j * om[:, None, None] * np.eye(n)[None] - self.A[None]
        return np.linalg.solve(M, np.broadcast_to(bvec, (len(om), n))[..., None])[:, j, 0]

    def transfer_functions(self) -> dict:
        """du/dtau and du/dpsi1 as python-control transfer functions ((2.70), (2.94): W_tau, W_1)."""
        sys = self.sys
        return {name: control.ss2tf(sys[self.u_out, i]) for i, name in enumerate(("W_tau", "W_1"))}


def exact(model: DynamicModel, p: np.ndarray | None = None, label: str | None = None) -> LinearModel:
    """Exact CasADi Jacobians of the nonlinear model at its equilibrium (x0, w0)."""
    A, B = jacobians(model)(model.x0, model.w0, model.p0 if p is None else p)
    A, B = np.array(A), np.array(B)[:, ::-1]  # inputs (psi1, tau) -> (tau, psi1)
    # report velocity states in physical units (du/dt, dxi/dt): v = t_ref du/dt
    S = np.diag([1.0 / model.t_ref if k in ("v", "w") else 1.0 for k in model.states])
    Si = np.linalg.inv(S)
    names = [{"v": "du", "w": "dxi"}.get(k, k) for k in model.states]
    return LinearModel(label=label or f"nonlinear_{model.form}", A=S @ A @ Si, B=S @ B, states=names,
                       b=model.design.groups.b, z_B=model.design.scales["z_B"], u_out=0,
                       info={"form": model.form, "point": model.point})


def jacobians(model: DynamicModel) -> ca.Function:
    """CasADi Function (x, w, p) -> (df/dx, df/dw), built once per model and cached."""
    cache = model.__dict__.setdefault("_cache", {})
    if "jac" not in cache:
        x = ca.SX.sym("x", len(model.states))
        w = ca.SX.sym("w", 2)
        p = ca.SX.sym("p", len(model.p0))
        f = model.ode(x, w, p)
        cache["jac"] = ca.Function("ode_jacobians", [x, w, p], [ca.jacobian(f, x), ca.jacobian(f, w)],
                                   ["x", "w", "p"], ["A", "B"])
    return cache["jac"]


def operator(model: DynamicModel, p: np.ndarray | None = None):
    """(N0, N1, N2, Gin) of the model's implicit rows at equilibrium, in the layout of (2.101):
    N(p) dq = Gin [dtau, dpsi1]."""
    n = len(model.coords)
    q, qd, qdd = ca.SX.sym("q", n), ca.SX.sym("qd", n), ca.SX.sym("qdd", n)
    w = ca.SX.sym("w", 2)
    pp = ca.SX.sym("p", len(model.p0))
    r = model.rows(q, qd, qdd, w, pp)
    f = ca.Function("op", [q, qd, qdd, w, pp],
                    [ca.jacobian(r, q), ca.jacobian(r, qd), ca.jacobian(r, qdd), ca.jacobian(r, w)])
    q0 = [float(model.point[k]) for k in model.coords]
    N0, N1, N2, Nw = (np.array(m) for m in f(q0, np.zeros(n), np.zeros(n), model.w0,
                                             model.p0 if p is None else p))
    return N0, N1, N2, -Nw[:, ::-1]


def hand(c: Constants, label: str | None = None) -> LinearModel:
    """The descriptor model of (2.43)/(2.101) as a StateSpace: E is nonsingular, so
    A_ss = E^-1 A and B_ss = E^-1 G."""
    E, A, G, names = c.descriptor()
    if abs(np.linalg.det(E)) == 0 or np.linalg.cond(E) > 1e15:
        raise ValueError("singular descriptor matrix E: the hand model has an algebraic row")
    return LinearModel(label=label or c.mode, A=np.linalg.solve(E, A), B=np.linalg.solve(E, G), states=names,
                       b=c.b, z_B=c.z_B, u_out=0, info={"mode": c.mode, "constants": dict(c.c)})


def finite_difference(model: DynamicModel, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of the ODE right-hand side at the equilibrium (test cross-check),
    in the model's own (scaled) states: compare with ``jacobians(model)``."""
    n = len(model.states)
    J = np.zeros((n, n))
    for j in range(n):
        d = np.zeros(n)
        d[j] = h * max(1.0, abs(model.x0[j]))
        fp = np.array(model.ode(model.x0 + d, model.w0, model.p0)).ravel()
        fm = np.array(model.ode(model.x0 - d, model.w0, model.p0)).ravel()
        J[:, j] = (fp - fm) / (2 * d[j])
    return J


class Setup:
    """One scene's device at one operating point, with every model the dynamic analyses name.

    ``nonlinear``/``nonlinear_chain``: exact linearization of models/dynamics.py (energy / chain
    chamber form) at the exact IPOPT static solution; ``consistent``: the hand model at the same
    point (equals ``nonlinear_chain``); ``program``/``thesis``: the hand model at the appendix's
    closed-form point (2.24)-(2.28) / (2.145)-(2.147), as the source computes it.

    Parameters
    ----------
    device : DeviceParams
        The device in SI with its dynamic data (``device.dynamics``).
    psi1 : float
        Discharge pressure ratio p1/p_B of the operating point (dimensionless).

    Raises
    ------
    SolveError
        When the operating point has the face in contact or the regulator valve on its stop.
    """

    def __init__(self, device: DeviceParams, psi1: float = 1.0):
        if device.dynamics is None:
            raise ValueError("the dynamic analyses need the device's dynamic data (DeviceParams.dynamics)")
        self.device = device
        self.dev = design(device)
        self.data = device.dynamics
        self.psi1 = psi1
        self.static = StaticsSolver(self.dev).solve(psi1, self.dev.dpsi)
        if self.static.contact or self.static.saturated:
            raise SolveError(f"operating point psi1 = {psi1:g} has the "
                             f"{'face in contact' if self.static.contact else 'regulator valve on its stop'}: "
                             "the dynamic model needs an open gap and a regulating valve",
                             "stop_reached", self.static.values)
        self.point = self.static.values | {"psi1": psi1, "dpsi": self.dev.dpsi}
        self.program_point = program_point(self.dev, psi1)
        self._models: dict = {}

    def nonlinear(self, form: str = "energy"):
        if form not in self._models:
            self._models[form] = build(self.dev, self.data, self.point, form)
        return self._models[form]

    def constants(self, mode: str, data=None):
        pt = self.point if mode == "consistent" else self.program_point
        return constants(self.dev, data or self.data, pt, mode)

    def linear(self, name: str, data=None) -> LinearModel:
        """The linear model called ``name`` (nonlinear, nonlinear_chain, program, thesis, consistent),
        optionally with changed dynamic data."""
        if name.startswith("nonlinear"):
            m = self.nonlinear("chain" if name == "nonlinear_chain" else "energy")
            return exact(m, None if data is None else data.vector(), label=name)
        return hand(self.constants(name, data), label=name)


def coefficient_table(setup: Setup) -> dict:
    """K1..K13, T1..T9, tau3..tau7, zeta1, zeta2 of the hand model in each mode beside the values read
    off the exact Jacobians of the nonlinear model's rows (chain and energy forms), with a note where
    they differ: ``{"names": [...], "columns": {model: {name: value}}, "notes": {name: text}, "extra": {...}}``
    (K, zeta dimensionless, T, tau in s; a constant a model does not have is left out, its ``<model>_status``
    names it)."""
    cols, extra = {}, {}
    for mode in ("program", "thesis", "consistent"):
        cols[mode] = dict(setup.constants(mode).c)
    # the formulas' own differences, free of the operating point: consistent mode at the program's point
    cols["consistent_at_program_point"] = dict(constants(setup.dev, setup.data, setup.program_point, "consistent").c)
    template = setup.constants("consistent")
    for name, form in (("nonlinear_chain", "chain"), ("nonlinear", "energy")):
        read, ex = from_operator(*operator(setup.nonlinear(form)), template)
        if not template.regulator:  # without the regulator only K9 + K11 is identifiable
            read["K11"] = read.pop("K9+K11") - cols["consistent"]["K9"]
        cols[name], extra[name] = read, ex
    names = [k for k in (*K_NAMES, *T_NAMES, *OTHER) if k in cols["consistent"]]
    notes = {}
    for k in names:
        c, e = cols["consistent"][k], cols["nonlinear"].get(k, math.nan)
        c0, p, t = (cols[m][k] for m in ("consistent_at_program_point", "program", "thesis"))
        diff = []
        for label, v in (("program", p), ("thesis", t)):
            if not math.isclose(v, c0, rel_tol=1e-6, abs_tol=0):
                diff.append(f"{label}/consistent = {v / c0:.4g} at the same point" if c0 else f"{label} differs")
        if math.isfinite(e) and not math.isclose(e, c, rel_tol=1e-6, abs_tol=1e-300):
            diff.append(f"energy form: {e + 0.0:.4g} (sign differs)" if e * c < 0 else f"energy form: {e + 0.0:.4g}")
        if diff:
            notes[k] = "; ".join(diff)
    columns = {m: {k: v[k] for k in names if k in v} for m, v in cols.items()}
    for m, v in cols.items():
        if any(k not in v for k in names):
            columns[f"{m}_status"] = (f"the {m} model has no such constant (left out): "
                                      + ", ".join(k for k in names if k not in v))
    return {"names": names, "columns": columns, "notes": notes, "extra": extra}
