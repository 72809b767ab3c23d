"""Stability-constrained design of the balancing device: one NLP over design variables and statics.

The design variables (chamber volumes, damping, regulator spring, the margin dpsi, the regulator
supply pressure) are found by IPOPT together with the static unknowns at a set of operating points
(discharge ratios psi1).  At each point:

* the static balances of :func:`autobal.models.device.static_system` are equality constraints, the
  margin dpsi and the supply pressure psi_in entering as symbols; both stops are held open
  (contact and valve reactions fixed at zero, the valve inside a band of its travel, the face gap
  inside the scene's bounds);
* the exact linearisation A = df/dx of :func:`autobal.models.dynamics.build` is evaluated at the
  symbolic static state, so A is a CasADi expression of the variables;
* every eigenvalue must satisfy Re lambda <= -alpha: the Routh-Hurwitz conditions (Gantmacher
  (1959), ch. XV; Pavlenko (2014), Eqs. (2.97)-(2.99)) of det(sI - A - alpha I) = s^n + a1 s^(n-1)
  + ... + an, as the first column r_1..r_n of the Routh array, every r_k >= 0 (the Hurwitz
  determinants are Delta_k = r_1 ... r_k, and r_n = a_n).  The coefficients are built exactly and
  smoothly: a fixed numeric balancing D, a symbolic Householder reduction to Hessenberg form, then
  La Budde's recursion (Rehman & Ipsen (2011)), which keeps them accurate over the 7 decades of
  time scales of the device (a direct Faddeev-LeVerrier or Berkowitz expansion loses them all);
* the static stiffness kappa_s = -d(sigma (psi2 - psi3))/du (Pavlenko (2014), Eq. (2.33)) by the
  implicit-function derivative of the same balances, at least a bound.

Objective: the barrier leakage Q_e at the nominal point (default), or minus the static stiffness,
or a weighted mix.  The optimum is certified by eigenvalues of the ordinary statics + linearisation
path (:class:`autobal.analysis.statics.StaticsSolver`, :func:`autobal.analysis.linearize.exact`) and
by a random search over the same variables.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.linalg

from autobal.analysis import ipopt
from autobal.analysis.linearize import exact, jacobians
from autobal.analysis.statics import StaticsSolver
from autobal.errors import SolveError
from autobal.models import throttles as th
from autobal.models.device import DeviceParams, design, static_system
from autobal.models.dynamics import PARAM_NAMES, build

# design keys: dynamic data (models/dynamics.PARAM_NAMES) and the two static parameters
DYNAMIC_KEYS = ("V2", "V3", "c_z", "c_x", "k_reg", "V_cam", "V_m")
STATIC_KEYS = ("dpsi", "p_in", "s_m", "d_e", "l_e", "d_in", "l_in")
UNITS = {"V2": "m**3", "V3": "m**3", "V_cam": "m**3", "V_m": "m**3", "c_z": "N*s/m", "c_x": "N*s/m",
         "k_reg": "N/m", "dpsi": "", "p_in": "Pa", "s_m": "m**2", "d_e": "m", "l_e": "m", "d_in": "m", "l_in": "m"}
# the laminar throttles a design may size: key prefix -> (group, where the tube is in DeviceParams)
TUBES = {"e": "alpha_e1", "in": "alpha_in1"}
OMEGA_REF = 1000.0  # rad/s, time scale of the characteristic polynomial
ACTIVE_TOL = 1e-6  # a constraint within this (scaled) distance of its bound ...
MULTIPLIER_TOL = 1e-3  # ... and with a multiplier above this (relative to the objective, O(1)) is active


@dataclass(frozen=True)
class Variable:
    """One design variable: the scene path it is written to, its key and its bounds (SI)."""

    path: str
    key: str
    lower: float
    upper: float


@dataclass(frozen=True)
class Spec:
    """What the design asks for (SI and dimensionless).

    Attributes
    ----------
    variables : tuple of Variable
    points : tuple of float
        Operating discharge ratios psi1 = p1/p_B.
    nominal_ratio : float
        psi1 of the objective's nominal point (one of ``points``).
    decay_rate : float
        alpha, 1/s: every eigenvalue Re lambda <= -alpha.
    gap : (float, float)
        Face gap bounds z, m.
    valve_band : float
        Fraction of the valve travel kept free at each end (off its seat and off its open stop).
    min_stiffness : float
        Lower bound of kappa_s (dimensionless); -inf: none.
    weights : (float, float)
        Objective weights of Q_e / Q_e,nominal and of -kappa_s / kappa_s,nominal.
    form : {"energy", "chain"}
        Chamber balances of the dynamic model.
    """

    variables: tuple
    points: tuple
    nominal_ratio: float = 1.0
    decay_rate: float = 0.0
    gap: tuple = (0.0, math.inf)
    valve_band: float = 0.05
    min_stiffness: float = -math.inf
    weights: tuple = (1.0, 0.0)
    form: str = "energy"


def apply(device: DeviceParams, values: dict) -> DeviceParams:
    """The device with design values (key -> SI float) substituted."""
    dyn = {k: v for k, v in values.items() if k in DYNAMIC_KEYS}
    out = dataclasses.replace(device, dynamics=dataclasses.replace(device.dynamics, **dyn))
    if "dpsi" in values:
        out = dataclasses.replace(out, barrier=dataclasses.replace(out.barrier, margin_ratio=values["dpsi"]))
    if "p_in" in values:
        out = dataclasses.replace(out, regulator=dataclasses.replace(out.regulator, supply_pressure=values["p_in"]))
    for t in TUBES:
        if f"d_{t}" in values or f"l_{t}" in values:
            old = out.barrier.supply_throttle if t == "e" else out.regulator.inlet_throttle
            tube = dataclasses.replace(old, diameter=values.get(f"d_{t}", old.diameter),
                                       length=values.get(f"l_{t}", old.length))
            if t == "e":
                out = dataclasses.replace(out, barrier=dataclasses.replace(out.barrier, supply_throttle=tube))
            else:
                out = dataclasses.replace(out, regulator=dataclasses.replace(out.regulator, inlet_throttle=tube))
    if "s_m" in values:  # the membrane area is the regulator's and the dynamic data's
        out = dataclasses.replace(out, regulator=dataclasses.replace(out.regulator, membrane_area=values["s_m"]),
                                  dynamics=dataclasses.replace(out.dynamics, s_m=values["s_m"]))
    return out


def nominal_values(device: DeviceParams, keys) -> dict:
    """Key -> SI value of the design keys in ``device``."""
    get = {"dpsi": lambda d: d.barrier.margin_ratio, "p_in": lambda d: d.regulator.supply_pressure,
           "s_m": lambda d: d.regulator.membrane_area,
           "d_e": lambda d: d.barrier.supply_throttle.diameter, "l_e": lambda d: d.barrier.supply_throttle.length,
           "d_in": lambda d: d.regulator.inlet_throttle.diameter, "l_in": lambda d: d.regulator.inlet_throttle.length}
    return {k: float(get[k](device) if k in get else getattr(device.dynamics, k)) for k in keys}


# ---- the characteristic polynomial and the Lienard-Chipart conditions, symbolically -------------

def hessenberg(A):
    """Householder reduction of a square CasADi matrix to upper Hessenberg form (similar to A)."""
    n = A.shape[0]
    H = A
    for k in range(n - 2):
        x = H[k + 1:, k]
        sign = ca.if_else(x[0] >= 0, 1.0, -1.0)
        v = ca.vertcat(x[0] + sign * ca.norm_2(x), x[1:])
        vv = ca.dot(v, v)
        P = ca.SX.eye(n)
        P[k + 1:, k + 1:] = ca.SX.eye(n - k - 1) - 2 * ca.mtimes(v, v.T) / vv
        H = ca.mtimes(ca.mtimes(P, H), P)
    return H


def charpoly_hessenberg(H) -> list:
    """Coefficients [1, a1, ..., an] of det(sI - H) of an upper Hessenberg H (La Budde's recursion)."""
    n = H.shape[0]
    P = [[ca.SX(1.0)]]
    for i in range(n):
        prev = P[i]
        p = [prev[0]] + [(prev[j] if j < len(prev) else 0) - H[i, i] * prev[j - 1] for j in range(1, i + 2)]
        prod = ca.SX(1.0)
        for m in range(1, i + 1):
            prod = prod * H[i - m + 1, i - m]
            t = P[i - m]
            off = len(p) - len(t)
            for j, c in enumerate(t):
                p[off + j] = p[off + j] - H[i - m, i] * prod * c
        P.append(p)
    return P[n]


def routh_column(a: list) -> list:
    """First column r_1..r_n of the Routh array of a0 s^n + a1 s^(n-1) + ... + an (a0 > 0);
    the Hurwitz determinants are Delta_k = r_1 ... r_k (Gantmacher (1959), ch. XV)."""
    n = len(a) - 1
    rows = [a[0::2], a[1::2]]
    col = [rows[1][0]]
    for _ in range(2, n + 1):
        top, mid = rows[-2], rows[-1]
        new = []
        for j in range(len(top) - 1):
            b = mid[j + 1] if j + 1 < len(mid) else 0.0
            new.append((mid[0] * top[j + 1] - top[0] * b) / mid[0])
        if not new:
            new = [0.0]
        rows.append(new)
        col.append(new[0])
    return col


def stability_conditions(A, alpha: float, balance: np.ndarray):
    """Routh-Hurwitz conditions of the shifted matrix A + alpha I: the first column r_1..r_n of the
    Routh array of det(sI - A - alpha I), every entry >= 0 iff every eigenvalue of A has
    Re <= -alpha (the Hurwitz determinants are Delta_k = r_1 ... r_k, r_n = a_n), as CasADi
    expressions: (names, expressions).

    Parameters
    ----------
    A : casadi.SX
        n x n system matrix, 1/s.
    alpha : float
        Decay-rate margin, 1/s.
    balance : numpy.ndarray
        Fixed diagonal similarity scaling (from the nominal matrix).
    """
    n = A.shape[0]
    D = ca.diag(ca.DM(balance))
    Di = ca.diag(ca.DM(1.0 / balance))
    As = ca.mtimes(ca.mtimes(Di, A + alpha * ca.SX.eye(n)), D) / OMEGA_REF
    a = charpoly_hessenberg(hessenberg(As))
    r = routh_column(a)
    return [f"routh{k}" for k in range(1, n + 1)], r


# ---- the NLP -------------------------------------------------------------------------------------

@dataclass
class Evaluation:
    """A design evaluated by the ordinary path (statics + exact linearisation + eigenvalues)."""

    values: dict  # key -> SI
    feasible: bool
    objective: float
    leakage: float  # Q_e at the nominal point, m^3/s
    abscissa: dict = field(default_factory=dict)  # psi1 -> max Re lambda, 1/s
    stiffness: dict = field(default_factory=dict)  # psi1 -> kappa_s
    gap: dict = field(default_factory=dict)  # psi1 -> z, m
    valve: dict = field(default_factory=dict)  # psi1 -> xi / xi_max
    reason: str = ""
    statics: dict = field(default_factory=dict, repr=False)  # psi1 -> static unknowns


class DesignProblem:
    """The design NLP of one device (see the module docstring).

    Parameters
    ----------
    device : DeviceParams
        The starting design, with dynamic data.
    spec : Spec
        Variables, operating points, margins, objective.
    """

    def __init__(self, device: DeviceParams, spec: Spec):
        if device.dynamics is None or device.regulator is None:
            raise ValueError("the design needs a device with a regulator and dynamic data")
        self.device, self.spec = device, spec
        self.keys = [v.key for v in spec.variables]
        self.points = sorted(set(spec.points) | {spec.nominal_ratio})
        self.nominal = nominal_values(device, self.keys)
        self.scale = np.array([max(abs(v.upper), abs(v.lower)) for v in spec.variables])
        self.dev0 = design(device)
        g = self.dev0.groups
        self.sys = static_system(g, parameters=("psi_in", "alpha_e1", "alpha_in1"))
        self.solver0 = StaticsSolver(self.dev0)
        self.statics0 = {p: self.solver0.solve(p, self.dev0.dpsi) for p in self.points}
        ref = self.statics0[spec.nominal_ratio]
        self.model = build(self.dev0, device.dynamics, ref.values | {"psi1": ref.psi1, "dpsi": ref.dpsi}, spec.form)
        self.ref0 = self._reference()
        self._build()

    # the SI values of the scaled variables y (symbolic or numeric)
    def _si(self, y):
        return {k: self.scale[i] * y[i] for i, k in enumerate(self.keys)}

    def _reference(self):
        """Nominal objective terms (leakage, stiffness) for scaling."""
        st = self.statics0[self.spec.nominal_ratio]
        return {"q_e": st.flows["e"], "kappa": self.solver0.stiffness(st)}

    def _states(self, W):
        """The dynamic model's state vector from the static unknowns (velocities zero)."""
        v = dict(zip(self.sys.unknowns, ca.vertsplit(W), strict=True))
        return ca.vertcat(*[0 if k in ("v", "w") else v[k] for k in self.model.states])

    def _stiffness(self, W, psi1, dpsi, theta):
        """kappa_s = -sigma d(psi2 - psi3)/du with the other balances held (stops open)."""
        return self.sys.stiffness(ca.jacobian(self.sys.residual(W, psi1, dpsi, theta), W))

    def _build(self):
        sp, sys_, g = self.spec, self.sys, self.dev0.groups
        nv, nw, m = len(self.keys), len(sys_.unknowns), len(self.points)
        y = ca.SX.sym("y", nv)
        W = ca.SX.sym("W", nw, m)
        si = self._si(y)
        p_b = self.dev0.scales["p_B"]
        dpsi = si.get("dpsi", self.dev0.dpsi)
        groups = self.groups(si)
        theta = ca.vertcat(si["p_in"] / p_b if "p_in" in si else g.regulator.psi_in,
                           groups["alpha_e1"], groups["alpha_in1"])
        pvec = ca.vertcat(*[si.get(k, self.model.p0[i]) for i, k in enumerate(PARAM_NAMES)])
        jac = self.linearisation(si, groups)
        cons, lo, hi, names = [], [], [], []

        def add(name, expr, lower, upper):
            cons.append(expr)
            lo.append(lower)
            hi.append(upper)
            names.append(name)

        # balancing of each point's nominal matrix (fixed numbers)
        self.balance = {}
        for j, p in enumerate(self.points):
            Wj = W[:, j]
            for e, r in zip(sys_.equations, ca.vertsplit(sys_.residual(Wj, p, dpsi, theta)), strict=True):
                add(f"psi1={p:g}: {e}", r, 0.0, 0.0)
            A = jac(self._states(Wj), ca.vertcat(p, g.b * p), pvec)
            A0 = np.array(jacobians(self.model)(self.static_state(p), [p, g.b * p], self.model.p0)[0])
            _, (bscale, _) = scipy.linalg.matrix_balance(A0 + sp.decay_rate * np.eye(len(A0)), permute=False,
                                                         separate=True)
            self.balance[p] = bscale
            cn, ce = stability_conditions(A, sp.decay_rate, bscale)
            for name, expr in zip(cn, ce, strict=True):
                add(f"psi1={p:g}: stability {name}", expr, 0.0, math.inf)
            if math.isfinite(sp.min_stiffness):
                add(f"psi1={p:g}: stiffness", self._stiffness(Wj, p, dpsi, theta), sp.min_stiffness, math.inf)
        jn = self.points.index(sp.nominal_ratio)
        q = sys_.flows(W[:, jn], sp.nominal_ratio, dpsi, theta)[0]
        q_e = q[sys_.throttles.index("e")]
        kappa = self._stiffness(W[:, jn], sp.nominal_ratio, dpsi, theta)
        f = sp.weights[0] * q_e / self.ref0["q_e"] - sp.weights[1] * kappa / abs(self.ref0["kappa"])
        x = ca.vertcat(y, ca.vec(W))
        g_all = ca.vertcat(*cons)
        # scale every constraint row by its magnitude at the start
        x0 = self.start()
        g0 = np.abs(np.array(ca.Function("g0", [x], [g_all])(x0)).ravel())
        s = np.where(g0 > 1e-300, g0, 1.0)
        s = np.where([n.endswith(("flow", "force")) for n in names], 1.0, s)
        self.g_scale = s
        self.names = names
        self.lbg = np.array(lo) / s
        self.ubg = np.array(hi) / s
        self._x, self._f, self._g = x, f, g_all / s
        self.q_e = ca.Function("q_e", [x], [q_e * self.dev0.scales["Q_scale"]])
        self.objective_fn = ca.Function("objective", [x], [f])
        self.solver = ipopt.nlpsol("design", x, ca.SX.sym("none", 0), f, self._g, warm=False,
                                   tol=1e-8, constr_viol_tol=1e-10, compl_inf_tol=1e-8, acceptable_tol=1e-6,
                                   acceptable_iter=5, max_iter=500)

    def groups(self, si: dict) -> dict:
        """The groups a design changes, from the SI values (CasADi or numbers): alpha_e1, alpha_in1
        (laminar throttles over g1, :func:`autobal.models.throttles.laminar_tube`) and s_m (m^2)."""
        mu, g1 = self.device.fluid.viscosity, self.dev0.scales["g1"]
        out = {"s_m": si.get("s_m", self.device.regulator.membrane_area)}
        for t, name in TUBES.items():
            tube = self.device.barrier.supply_throttle if t == "e" else self.device.regulator.inlet_throttle
            out[name] = th.laminar_tube(si.get(f"d_{t}", tube.diameter), si.get(f"l_{t}", tube.length), mu) / g1
        return out

    def linearisation(self, si: dict, groups: dict | None = None):
        """(x, w, p) -> A of the model, with s_m, alpha_e1 and alpha_in1 symbolic when the design changes them.

        The model is affine in each of them jointly (the membrane force sigma_m (psi_e - psi1 - dpsi) of
        the stem and the displacement flow s_m dx/dt of the barrier chamber; the laminar flows
        alpha (psi_a - psi_b); the mass matrix contains none of them, and no product of two appears), so
        A = A(nominal) + sum_i t_i (A(moved i) - A(nominal)), t_i = (theta_i - theta_i0)/(theta_i1 -
        theta_i0), exactly, from one extra built model per group.  The static point off the valve stop
        does not depend on s_m (psi_e = psi1 + dpsi); it does on the alphas, through the statics' symbols.
        """
        groups = self.groups(si) if groups is None else groups
        jac0 = jacobians(self.model)
        ref = self.statics0[self.spec.nominal_ratio]
        point = ref.values | {"psi1": ref.psi1, "dpsi": ref.dpsi}
        nominal = self.groups({})
        terms = []
        moves = {"s_m": ("s_m",), "alpha_e1": ("d_e", "l_e"), "alpha_in1": ("d_in", "l_in")}
        for name, keys in moves.items():
            if not any(k in si for k in keys):
                continue
            key = keys[0]
            v0 = nominal_values(self.device, [key])[key]
            dev1 = apply(self.device, {key: 1.5 * v0})
            moved = self.groups({key: 1.5 * v0})[name]
            jac1 = jacobians(build(design(dev1), dev1.dynamics, point, self.spec.form))
            terms.append(((groups[name] - nominal[name]) / (moved - nominal[name]), jac1))

        def A(x, w, p):
            a0 = jac0(x, w, p)[0]
            for t, j in terms:
                a0 = a0 + t * (j(x, w, p)[0] - jac0(x, w, p)[0])
            return a0

        return A

    def static_state(self, p):
        """The dynamic model's state at the starting design's static solution at psi1 = ``p``."""
        st = self.statics0[p]
        v = dict(zip(self.sys.unknowns, st.x, strict=True))
        return np.array([0.0 if k in ("v", "w") else v[k] for k in self.model.states])

    def start(self, ev: Evaluation | None = None) -> np.ndarray:
        """Initial point: the starting design and its statics, or an evaluated design ``ev``."""
        vals = self.nominal if ev is None else ev.values
        y0 = np.array([vals[k] for k in self.keys]) / self.scale
        y0 = np.clip(y0, [v.lower / s for v, s in zip(self.spec.variables, self.scale, strict=True)],
                     [v.upper / s for v, s in zip(self.spec.variables, self.scale, strict=True)])
        W0 = np.column_stack([self.statics0[p].x if ev is None else ev.statics[p] for p in self.points])
        return np.concatenate([y0, W0.ravel(order="F")])

    def bounds(self):
        """(lbx, ubx) of the NLP: the variables' boxes (scaled by their largest bound) and, per point,
        the static unknowns with both reactions fixed at zero, the face gap u = z/z_B and the valve
        opening xi inside the spec's bands."""
        sp, sys_ = self.spec, self.sys
        xi_max = self.dev0.groups.regulator.xi_max
        z_b = self.dev0.scales["z_B"]
        lb, ub = np.array(sys_.lower, float), np.array(sys_.upper, float)
        fix = {"r_contact": (0.0, 0.0), "r_valve": (0.0, 0.0),
               "u": (sp.gap[0] / z_b, sp.gap[1] / z_b),
               "xi": (sp.valve_band * xi_max, (1 - sp.valve_band) * xi_max)}
        for k, (lo, hi) in fix.items():
            if k in sys_.unknowns:
                lb[sys_.index(k)], ub[sys_.index(k)] = lo, hi
        m = len(self.points)
        ylo = [v.lower / s for v, s in zip(sp.variables, self.scale, strict=True)]
        yhi = [v.upper / s for v, s in zip(sp.variables, self.scale, strict=True)]
        return np.concatenate([ylo, np.tile(lb, m)]), np.concatenate([yhi, np.tile(ub, m)])

    def solve(self, start: Evaluation | None = None) -> dict:
        """Solve the design NLP from the starting design (or from ``start``); SolveError if IPOPT fails."""
        lbx, ubx = self.bounds()
        x0 = np.clip(self.start(start), lbx, ubx)
        res = ipopt.solve(self.solver, x0=x0, lbx=lbx, ubx=ubx, lbg=self.lbg, ubg=self.ubg)
        hist = self.solver.stats().get("iterations", {})
        if not res["success"]:
            raise SolveError("the design NLP did not converge", res["status"],
                             dict(zip(self.keys, self.scale * res["x"][:len(self.keys)], strict=True)))
        x = res["x"]
        values = {k: float(self.scale[i] * x[i]) for i, k in enumerate(self.keys)}
        return {"values": values, "x": x, "res": res, "history": {k: list(hist.get(k, [])) for k in ("obj", "inf_pr",
                                                                                                       "inf_du")},
                "active": self.active(res, lbx, ubx)}

    def active(self, res, lbx, ubx) -> list[dict]:
        """Constraints at their bounds with their multipliers (scaled rows; variables by path)."""
        out = []
        g, lam = res["g"], res["lam_g"]
        for i, n in enumerate(self.names):
            if self.lbg[i] == self.ubg[i]:
                continue  # the static balances: always active
            near = min(abs(g[i] - self.lbg[i]), abs(g[i] - self.ubg[i]))
            if near < ACTIVE_TOL and abs(lam[i]) > MULTIPLIER_TOL:
                out.append({"constraint": n, "multiplier": float(lam[i]), "value": float(g[i])})
        x, lamx = res["x"], res["lam_x"]
        labels = [v.path for v in self.spec.variables] + [f"psi1={p:g}: {k}" for p in self.points
                                                           for k in self.sys.unknowns]
        for i, n in enumerate(labels):
            if n.endswith(("r_contact", "r_valve")):
                continue
            near = min(abs(x[i] - lbx[i]), abs(x[i] - ubx[i]))
            if near < ACTIVE_TOL * max(1.0, abs(x[i])) and abs(lamx[i]) > MULTIPLIER_TOL:
                side = "lower" if abs(x[i] - lbx[i]) <= abs(x[i] - ubx[i]) else "upper"
                out.append({"constraint": f"{n} {side} bound", "multiplier": float(lamx[i]), "value": float(x[i])})
        return out

    # ---- the ordinary path --------------------------------------------------------------------
    def evaluate(self, values: dict, points=None, form: str | None = None) -> Evaluation:
        """Statics + exact linearisation + eigenvalues at every operating point (or at ``points``)
        for the design ``values`` (key -> SI), with the spec's dynamic model (or ``form``)."""
        sp = self.spec
        dev_p = apply(self.device, values)
        dd = design(dev_p)
        solver = StaticsSolver(dd)
        ev = Evaluation(values=dict(values), feasible=True, objective=math.nan, leakage=math.nan)
        xi_max = dd.groups.regulator.xi_max
        for p in self.points if points is None else [float(x) for x in points]:
            try:
                st = solver.solve(p, dd.dpsi)
            except SolveError as exc:
                ev.feasible, ev.reason = False, f"psi1={p:g}: statics failed ({exc})"
                continue
            ev.statics[p] = st.x
            z = st.values["u"] * dd.scales["z_B"]
            ev.gap[p], ev.valve[p] = z, st.values["xi"] / xi_max
            if st.contact or st.saturated:
                ev.feasible, ev.reason = False, f"psi1={p:g}: on a stop"
                ev.abscissa[p] = math.nan
                continue
            model = build(dd, dev_p.dynamics, st.values | {"psi1": p, "dpsi": dd.dpsi}, form or sp.form)
            ev.abscissa[p] = float(exact(model).poles().real.max())
            ev.stiffness[p] = solver.stiffness(st)
            tol = 1e-6
            checks = {
                "decay rate": ev.abscissa[p] <= -sp.decay_rate * (1 - tol) + tol,
                "face gap": sp.gap[0] * (1 - tol) <= z <= sp.gap[1] * (1 + tol),
                "valve band": sp.valve_band - tol <= ev.valve[p] <= 1 - sp.valve_band + tol,
                "stiffness": ev.stiffness[p] >= sp.min_stiffness - tol * abs(sp.min_stiffness),
            }
            bad = [k for k, ok in checks.items() if not ok]
            if bad:
                ev.feasible, ev.reason = False, f"psi1={p:g}: {', '.join(bad)}"
            if p == sp.nominal_ratio:
                ev.leakage = st.flows["e"] * dd.scales["Q_scale"]
                ev.objective = (sp.weights[0] * st.flows["e"] / self.ref0["q_e"]
                                - sp.weights[1] * ev.stiffness[p] / abs(self.ref0["kappa"]))
        return ev

    def sample(self, n: int, seed: int = 0) -> list[Evaluation]:
        """Random search: ``n`` designs uniform in the variables' box (log-uniform where the bounds
        span more than a decade and are positive), each evaluated by :meth:`evaluate`."""
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(n):
            vals = {}
            for v in self.spec.variables:
                if v.lower > 0 and v.upper / v.lower > 10:
                    vals[v.key] = float(np.exp(rng.uniform(math.log(v.lower), math.log(v.upper))))
                else:
                    vals[v.key] = float(rng.uniform(v.lower, v.upper))
            out.append(self.evaluate(vals))
        return out
