"""Stability-constrained design of the balancing device: one NLP over design variables and statics.

The design variables (chamber volumes, damping, regulator spring, the margin dpsi, the regulator
supply pressure, throttle and seal geometry, the face base gap and diameters, the valve base opening)
are found by IPOPT together with the static unknowns at a set of operating points
(discharge ratios psi1).  At each point:

* the static balances of :func:`autobal.models.device.static_system` are equality constraints, the
  margin dpsi and the supply pressure psi_in entering as symbols; both stops are held open
  (contact and valve reactions fixed at zero, the valve inside a band of its travel, the face gap
  inside the scene's bounds);
* the exact linearisation A = df/dx of :func:`autobal.models.dynamics.build` (built with the design
  variables as symbols where they move a scale g1, z_B, x_B, s_e; see DesignProblem.linearisation) is
  evaluated at the symbolic static state, so A is a CasADi expression of the variables;
* every eigenvalue must satisfy Re lambda <= -alpha: the Routh-Hurwitz conditions (Gantmacher
  (1959), ch. XV; Pavlenko (2014), Eqs. (2.97)-(2.99)) of det(sI - A - alpha I) = s^n + a1 s^(n-1)
  + ... + an, as the first column r_1..r_(n-1) of the Routh array and a_n, every one >= 0 (the
  Hurwitz determinants are Delta_k = r_1 ... r_k, and r_n = a_n).  The coefficients are built exactly and
  smoothly: a fixed numeric balancing D, a symbolic Householder reduction to Hessenberg form, then
  La Budde's recursion (Rehman & Ipsen (2011)), which keeps them accurate over the 7 decades of
  time scales of the device (a direct Faddeev-LeVerrier or Berkowitz expansion loses them all);
* the static stiffness kappa_s = -d(sigma (psi2 - psi3))/du (Pavlenko (2014), Eq. (2.33)) by the
  implicit-function derivative of the same balances, at least a bound.

Objective: the barrier leakage Q_e at the nominal point (default), or minus the static stiffness,
or a weighted mix.  The optimum is certified by eigenvalues of the ordinary statics + linearisation
path (:class:`autobal.analysis.numerics.statics.StaticsSolver`, :func:`autobal.analysis.numerics.linearize.exact`) and
by a random search over the same variables.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.linalg

from autobal.analysis.numerics import ipopt
from autobal.analysis.numerics.linearize import exact, jacobians
from autobal.analysis.numerics.statics import StaticsSolver
from autobal.analysis.run import solver_options
from autobal.errors import ScenarioError, SolveError
from autobal.models.device import REGULATOR_GROUPS, DeviceParams, design, groups_by_name, static_system
from autobal.models.dynamics import LONG_NAMES, PARAM_NAMES, build

# design key -> the DeviceParams fields it sets (dotted paths); their units are declared with the fields
# (models/device.py, models/dynamics.py)
FIELDS = {
    "V2": ("dynamics.V2",), "V3": ("dynamics.V3",), "c_z": ("dynamics.c_z",), "c_x": ("dynamics.c_x",),
    "k_reg": ("dynamics.k_reg",), "V_cam": ("dynamics.V_cam",), "V_m": ("dynamics.V_m",),
    "dpsi": ("barrier.margin_ratio",), "p_in": ("regulator.supply_pressure",),
    "s_m": ("regulator.membrane_area", "dynamics.s_m"),  # the regulator's and the dynamic data's
    "d_e": ("barrier.supply_throttle.diameter",), "l_e": ("barrier.supply_throttle.length",),
    "d_in": ("regulator.inlet_throttle.diameter",), "l_in": ("regulator.inlet_throttle.length",),
    "h_3": ("disc.outer_seal.clearance",), "l_3": ("disc.outer_seal.length",), "d_3": ("disc.outer_seal.diameter",),
    "zeta_3": ("disc.outer_seal.local_loss",), "lambda_3": ("disc.outer_seal.friction",),
    "lambda_T": ("disc.face.friction",), "phi_B": ("regulator.valve.discharge_coefficient",),
    "h_1": ("disc.inner_seal.clearance",), "l_1": ("disc.inner_seal.length",), "d_1": ("disc.inner_seal.diameter",),
    "z_B": ("disc.face.base_gap",), "x_B": ("regulator.valve.base_opening",),
    "d_T2": ("disc.face.inner_diameter",), "d_T3": ("disc.face.outer_diameter",),
    "d_c": ("regulator.valve.seat_diameter",),  # and the seat area s_c = pi d_c^2 / 4 (SEAT_AREA)
}
#: DeviceParams field -> design key (the first field a key sets)
_BY_FIELD = {fields[0]: key for key, fields in FIELDS.items()}


def variable_key(path: str) -> str | None:
    """The design key of a scene path (``device.disc.outer_seal.clearance`` -> ``h_3``), None if none: the key
    that sets the DeviceParams field the path names (a dynamic parameter by its scene name, LONG_NAMES)."""
    parts = path.split(".")
    if parts[:2] == ["device", "dynamics"]:
        return _BY_FIELD.get("dynamics." + LONG_NAMES.get(parts[-1], ""))
    return _BY_FIELD.get(".".join(parts[1:])) if parts[0] == "device" else None


# the dynamic data's seat area follows the valve seat diameter where the scene derives it (autobal/parts/device.py)
SEAT_AREA = "dynamics.s_c"
UNITS = {"V2": "m**3", "V3": "m**3", "V_cam": "m**3", "V_m": "m**3", "c_z": "N*s/m", "c_x": "N*s/m",
         "k_reg": "N/m", "dpsi": "", "p_in": "Pa", "s_m": "m**2", "d_e": "m", "l_e": "m", "d_in": "m", "l_in": "m",
         "h_3": "m", "l_3": "m", "d_3": "m", "zeta_3": "", "lambda_3": "", "lambda_T": "", "phi_B": "",
         "h_1": "m", "l_1": "m", "d_1": "m", "z_B": "m", "x_B": "m", "d_T2": "m", "d_T3": "m", "d_c": "m"}
# groups the dynamic model is affine in, jointly (see DesignProblem.linearisation); psi_in does not enter A
AFFINE_GROUPS = ("sigma_m", "alpha_e1", "alpha_in1", "alpha_TB1", "alpha_31", "alpha_B1")
# scales a design variable may move (symbolic in the NLP); p_B and s_B are the operating point's
DESIGN_SCALES = ("g1", "Q_scale", "z_B", "x_B", "s_e")
OMEGA_REF = 1000.0  # rad/s, time scale of the characteristic polynomial
ACTIVE_TOL = 1e-6  # a constraint within this (scaled) distance of its bound ...
MULTIPLIER_TOL = 1e-3  # ... and with a multiplier above this (relative to the objective, O(1)) is active
# the design's IPOPT options (the adaptive barrier, and the monotone one second where it fails): the groups
# "design" and "design_fallback" of analysis/run/solver_options.py, with the measurements that chose them


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
        Lower bound of kappa_s (dimensionless, per unit z / z_B of the starting design); -inf: none.
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


def _replace(obj, path: str, value):
    head, _, rest = path.partition(".")
    return dataclasses.replace(obj, **{head: _replace(getattr(obj, head), rest, value) if rest else value})


def apply(device: DeviceParams, values: dict) -> DeviceParams:
    """The device with design values (key -> SI number or CasADi expression) substituted; the valve
    seat diameter d_c also sets the dynamic data's seat area s_c = pi d_c^2 / 4 (the device adapter's default)."""
    for k, v in values.items():
        for path in FIELDS[k]:
            device = _replace(device, path, v)
        if k == "d_c" and device.dynamics is not None:
            device = _replace(device, SEAT_AREA, math.pi * v**2 / 4)
    return device


def nominal_values(device: DeviceParams, keys) -> dict:
    """Key -> SI value of the design keys in ``device``."""
    out = {}
    for k in keys:
        v = device
        for name in FIELDS[k][0].split("."):
            v = getattr(v, name)
        out[k] = float(v)
    return out


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
    """Routh-Hurwitz conditions of the shifted matrix A + alpha I: the first column r_1..r_(n-1) of the
    Routh array of det(sI - A - alpha I) and its constant coefficient a_n, every entry >= 0 iff every
    eigenvalue of A has Re <= -alpha (the Hurwitz determinants are Delta_k = r_1 ... r_k, and
    r_n = a_n), as CasADi expressions: (names, expressions).  At the stability boundary only
    r_(n-1) (a complex pair on Re = -alpha) or a_n (a real root there) vanishes, and both are smooth
    there; the Routh quotient for r_n would be 0/0.

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
    # r_n = a_n Delta_(n-1) / Delta_(n-1) is computed by the Routh array as a quotient by r_(n-1), which
    # vanishes where a complex pair crosses Re = -alpha (the boundary an optimum rests on): 0/0 there.
    # The constant coefficient a_n itself is the same condition, and a polynomial.
    r = routh_column(a)[:-1] + [a[-1]]
    return [f"routh{k}" for k in range(1, n)] + [f"a{n}"], r


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
        d_c = device.regulator.valve.seat_diameter
        if "d_c" in self.keys and not math.isclose(device.dynamics.s_c, math.pi * d_c**2 / 4, rel_tol=1e-12):
            raise ScenarioError("device.regulator.valve.seat_diameter: not a design variable where the scene gives "
                                "device.dynamics.regulator.seat_area (m^2) on its own: the design would move s_c "
                                "with d_c and --set would not")
        self.points = sorted(set(spec.points) | {spec.nominal_ratio})
        self.nominal = nominal_values(device, self.keys)
        self.scale = np.array([max(abs(v.upper), abs(v.lower)) for v in spec.variables])
        self.dev0 = design(device)
        g = self.dev0.groups
        self.moved, self.moved_scales = self._moved_groups()
        self.parameters = ("psi_in", *[k for k in self.moved if k != "psi_in"])
        self.sys = static_system(g, parameters=self.parameters)
        self.solver0 = StaticsSolver(self.dev0)
        self.statics0 = {p: self.solver0.solve(p, self.dev0.dpsi) for p in self.points}
        ref = self.statics0[spec.nominal_ratio]
        self.model = build(self.dev0, device.dynamics, ref.values | {"psi1": ref.psi1, "dpsi": ref.dpsi}, spec.form)
        self.ref0 = self._reference()
        self._build()

    # the SI values of the scaled variables y (symbolic or numeric)
    def _si(self, y):
        return {k: self.scale[i] * y[i] for i, k in enumerate(self.keys)}

    def _moved_groups(self) -> tuple:
        """(groups, scales) the design variables change, found by moving each by a tenth of its value;
        ValueError for a variable that changes the pressure or force scale (p_B, s_B) or the
        axial-force ratio b (the operating point's, not the device's)."""
        g0, out, scales_out = groups_by_name(self.dev0.groups), [], []
        for k in self.keys:
            if FIELDS[k][0].startswith("dynamics.") or k == "dpsi":
                continue
            v0 = self.nominal[k]
            moved = design(apply(self.device, {k: 1.1 * v0 if v0 else 1.0}))
            changed = [n for n, v in groups_by_name(moved.groups).items() if v != g0[n]]
            scales = [n for n, v in moved.scales.items() if not (v == self.dev0.scales[n] or v != v)]
            bad = [n for n in scales if n not in DESIGN_SCALES] + [n for n in changed if n == "b"]
            if bad:
                raise ValueError(f"design variable {k!r} changes {', '.join(bad)}: not a design variable yet")
            out += [n for n in changed if n not in out]
            scales_out += [n for n in scales if n not in scales_out]
        return tuple(out), tuple(scales_out)

    def _reference(self):
        """Nominal objective terms (leakage, stiffness) for scaling."""
        st = self.statics0[self.spec.nominal_ratio]
        return {"q_e": st.flows["e"], "kappa": self.solver0.stiffness(st)}

    def _states(self, W):
        """The dynamic model's state vector from the static unknowns (velocities zero)."""
        v = dict(zip(self.sys.unknowns, ca.vertsplit(W), strict=True))
        return ca.vertcat(*[0 if k in ("v", "w") else v[k] for k in self.model.states])

    def _stiffness(self, W, psi1, dpsi, theta, sigma=None, z_b=None):
        """kappa_s = -sigma d(psi2 - psi3)/du with the other balances held (stops open), per unit
        z / z_B of the starting design (times z_B0 / ``z_b``: the same SI stiffness when z_B moves)."""
        kappa = self.sys.stiffness(ca.jacobian(self.sys.residual(W, psi1, dpsi, theta), W), sigma=sigma)
        return kappa if z_b is None else kappa * (self.dev0.scales["z_B"] / z_b)

    def _build(self):
        sp, sys_, g = self.spec, self.sys, self.dev0.groups
        nv, nw, m = len(self.keys), len(sys_.unknowns), len(self.points)
        y = ca.SX.sym("y", nv)
        W = ca.SX.sym("W", nw, m)
        si = self._si(y)
        dpsi = si.get("dpsi", self.dev0.dpsi)
        dev_si = apply(self.device, si)
        dd = design(dev_si)
        groups, scales = groups_by_name(dd.groups), dd.scales
        theta = ca.vertcat(*[groups[n] for n in self.parameters])
        sigma = groups["sigma"] if "sigma" in self.moved else None
        z_b = scales["z_B"] if "z_B" in self.moved_scales else None
        pvec = ca.vertcat(*[getattr(dev_si.dynamics, k) for k in PARAM_NAMES])
        jac = self.linearisation(si, groups)
        z0, reg0 = self.dev0.scales["z_B"], self.dev0.groups.regulator
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
                kappa_j = self._stiffness(Wj, p, dpsi, theta, sigma, z_b)
                add(f"psi1={p:g}: stiffness", kappa_j, sp.min_stiffness, math.inf)
            # a moved scale turns the face-gap and valve-band bounds into constraints (see bounds())
            if "z_B" in self.moved_scales:
                add(f"psi1={p:g}: face gap", Wj[sys_.index("u")] * scales["z_B"] / z0, sp.gap[0] / z0,
                    sp.gap[1] / z0)
            if "x_B" in self.moved_scales and math.isfinite(reg0.xi_max):
                add(f"psi1={p:g}: valve band", Wj[sys_.index("xi")] / dd.groups.regulator.xi_max,
                    sp.valve_band, 1 - sp.valve_band)
        jn = self.points.index(sp.nominal_ratio)
        q = sys_.flows(W[:, jn], sp.nominal_ratio, dpsi, theta)[0]
        # the leakage in SI over its nominal value: the flow scale g1 p_B may be a design expression
        q_e = q[sys_.throttles.index("e")]
        if "Q_scale" in self.moved_scales:
            q_e = q_e * (scales["Q_scale"] / self.dev0.scales["Q_scale"])
        kappa = self._stiffness(W[:, jn], sp.nominal_ratio, dpsi, theta, sigma, z_b)
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
        self.solver = ipopt.nlpsol("design", x, ca.SX.sym("none", 0), f, self._g, **solver_options.get("design"))
        self._fallback = None

    def groups(self, si: dict) -> dict:
        """Every dimensionless group (name -> value) of the design ``si`` (key -> SI number or CasADi
        expression), by :func:`autobal.models.device.design` itself: symbolic where the design is."""
        return groups_by_name(design(apply(self.device, si)).groups)

    def _moved_jacobian(self, name: str):
        """Jacobians of the model built with group ``name`` at 1.5 times its nominal value (the
        membrane area s_m of the dynamic data moves with sigma_m = s_m / s_B)."""
        cache = self.__dict__.setdefault("_moved_jac", {})
        if name not in cache:
            g, data = self.dev0.groups, self.device.dynamics
            value = 1.5 * groups_by_name(g)[name]
            if name in REGULATOR_GROUPS:
                g = dataclasses.replace(g, regulator=dataclasses.replace(g.regulator, **{name: value}))
            else:
                g = dataclasses.replace(g, **{name: value})
            if name == "sigma_m":
                data = dataclasses.replace(data, s_m=1.5 * data.s_m)
            ref = self.statics0[self.spec.nominal_ratio]
            point = ref.values | {"psi1": ref.psi1, "dpsi": ref.dpsi}
            cache[name] = jacobians(build(dataclasses.replace(self.dev0, groups=g), data, point, self.spec.form))
        return cache[name]

    def linearisation(self, si: dict, groups: dict | None = None):
        """(x, w, p) -> A = df/dx of the dynamic model at the design ``si`` (key -> SI number or CasADi
        expression; keys not given: the starting design's); ``groups``: its groups, if built already
        (the same expressions, so the NLP's graph shares them).

        Where a variable moves a scale (g1, z_B, x_B, s_e) or a group outside AFFINE_GROUPS (sigma),
        the model built once with the design variables as symbols
        (:func:`autobal.models.dynamics.build` with ``symbols``) gives A exactly.  Otherwise the
        cheaper, better-conditioned affine form is used: the model is affine in the groups of
        AFFINE_GROUPS jointly (the membrane force sigma_m (psi_e - psi1 - dpsi) and displacement flow
        s_m dx/dt, the throttle flows alpha f(psi_a, psi_b); the mass matrix contains none of them,
        no product of two appears), so A = A(nominal) + sum_i t_i (A(moved i) - A(nominal)),
        t_i = (theta_i - theta_i0)/(theta_i1 - theta_i0), exactly, from one extra built model per group
        (the same IPOPT path as before the scales could move: the chain-form designs sit at the edge
        of what IPOPT converges, and the symbolic model's different rounding tips them over).
        """
        if self.moved_scales or any(n not in AFFINE_GROUPS + ("psi_in",) for n in self.moved):
            cache = self.__dict__.setdefault("_jac", [])
            if not cache:
                # the model with the design variables as symbols d (SI): groups and scales symbolic; the
                # dynamic data of PARAM_NAMES enter through its parameter vector p instead
                d = ca.SX.sym("d", len(self.keys))
                sym = apply(self.device, {k: d[i] for i, k in enumerate(self.keys)
                                          if not FIELDS[k][0].startswith("dynamics.")})
                sym = _replace(sym, SEAT_AREA, self.device.dynamics.s_c)  # s_c enters through p
                ref = self.statics0[self.spec.nominal_ratio]
                m = build(design(sym), sym.dynamics, ref.values | {"psi1": ref.psi1, "dpsi": ref.dpsi},
                          self.spec.form, symbols=d, values=[self.nominal[k] for k in self.keys])
                x, w, p = ca.SX.sym("x", len(m.states)), ca.SX.sym("w", 2), ca.SX.sym("p", len(m.p0))
                cache.append(ca.Function("A", [x, w, p, d], [ca.jacobian(m.ode(x, w, p, d), x)]))
            d = ca.vertcat(*[si.get(k, self.nominal[k]) for k in self.keys])
            return lambda x, w, p: cache[0](x, w, p, d)
        groups = self.groups(si) if groups is None else groups
        jac0 = jacobians(self.model)
        nominal = groups_by_name(self.dev0.groups)
        terms = [((groups[n] - nominal[n]) / (0.5 * nominal[n]), self._moved_jacobian(n))
                 for n in self.moved if n != "psi_in"]

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
        # a moved scale: these bands are constraints of the NLP (_build), the unknowns only nonnegative
        if "z_B" in self.moved_scales:
            fix["u"] = (0.0, math.inf)
        if "x_B" in self.moved_scales:
            fix["xi"] = (0.0, math.inf)
        for k, (lo, hi) in fix.items():
            if k in sys_.unknowns:
                lb[sys_.index(k)], ub[sys_.index(k)] = lo, hi
        m = len(self.points)
        ylo = [v.lower / s for v, s in zip(sp.variables, self.scale, strict=True)]
        yhi = [v.upper / s for v, s in zip(sp.variables, self.scale, strict=True)]
        return np.concatenate([ylo, np.tile(lb, m)]), np.concatenate([yhi, np.tile(ub, m)])

    def fallback_solver(self):
        """The same NLP with IPOPT's monotone barrier ("design_fallback" options), built on first use."""
        if self._fallback is None:
            self._fallback = ipopt.nlpsol("design_monotone", self._x, ca.SX.sym("none", 0), self._f, self._g,
                                          **(solver_options.get("design") | solver_options.get("design_fallback")))
        return self._fallback

    def solve(self, start: Evaluation | None = None) -> dict:
        """Solve the design NLP from the starting design (or from ``start``) with the adaptive barrier and,
        if that fails, with the monotone one; SolveError if both fail (the status is the last one's)."""
        lbx, ubx = self.bounds()
        x0 = np.clip(self.start(start), lbx, ubx)
        for solver in (self.solver, None):
            solver = solver or self.fallback_solver()
            res = ipopt.solve(solver, x0=x0, lbx=lbx, ubx=ubx, lbg=self.lbg, ubg=self.ubg)
            hist = solver.stats().get("iterations", {})
            if res["success"]:
                break
        res["barrier"] = "adaptive" if solver is self.solver else "monotone"
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
            # per unit z / z_B of the starting design (the same SI stiffness when z_B moves)
            ev.stiffness[p] = solver.stiffness(st) * self.dev0.scales["z_B"] / dd.scales["z_B"]
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
                ev.objective = (sp.weights[0] * ev.leakage / (self.ref0["q_e"] * self.dev0.scales["Q_scale"])
                                - sp.weights[1] * ev.stiffness[p] / abs(self.ref0["kappa"]))
        return ev

    def sample(self, n: int, seed: int = 0, around: dict | None = None, radius: float = 0.02) -> list[Evaluation]:
        """Random search: ``n`` designs uniform in the variables' box (log-uniform where the bounds
        span more than a decade and are positive), or, with ``around`` (key -> SI), uniform in a box of
        +-``radius`` of each variable's range about that design (clipped to the bounds), each evaluated
        by :meth:`evaluate`."""
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(n):
            vals = {}
            for v in self.spec.variables:
                if around is not None:
                    half = radius * (v.upper - v.lower)
                    lo, hi = max(v.lower, around[v.key] - half), min(v.upper, around[v.key] + half)
                    vals[v.key] = float(rng.uniform(lo, hi))
                elif v.lower > 0 and v.upper / v.lower > 10:
                    vals[v.key] = float(np.exp(rng.uniform(math.log(v.lower), math.log(v.upper))))
                else:
                    vals[v.key] = float(rng.uniform(v.lower, v.upper))
            out.append(self.evaluate(vals))
        return out
