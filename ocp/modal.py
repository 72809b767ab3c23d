"""Minimum-peak spin-up of a multi-mode rotor (a ROSS rotor reduced to its modes,
:mod:`autobal.models.ross_rotor`) through two or more critical speeds.

The drive is posed as in the Jeffcott scenes: |alpha| <= alpha_max, omega_final reached by the deadline
(``horizon``), held over ``settling_time`` (the peak counts over the whole window), omega <= omega_max.
The objective is the peak over time of the largest lateral deflection sqrt(x^2 + y^2) at the nodes of
interest, or (``min_time``) the arrival time with that deflection at most ``deflection_limit`` (the time-optimal
study of :mod:`autobal.ocp.time_optimal`, run on this problem as on the Jeffcott rotor's).

What is modal lives here: the problem (:class:`ModalSpinupOcp`: the complex envelope S of the modal state,
s = Re(S e^{i phi}) (:mod:`autobal.models.ross_rotor`), smooth where the rotor whirls at the running speed; the
deflection envelope of a node with complex amplitudes (X, Y), the major half-axis of its orbit,
r^2 = (|X|^2 + |Y|^2 + |X^2 + Y^2|)/2, smoothed: |W| -> sqrt(|W|^2 + eps^2); the epigraph r^2 <= S ref at every
collocation point, minimise S; or r^2 <= deflection_limit^2 there), the starts (a grid of four-phase speed
profiles: full acceleration to w1, a middle phase, full acceleration to w3, then the constant acceleration that
arrives at the deadline, screened by a fixed-step Runge-Kutta integration of the same envelope equation,
:func:`screen`), and the physical re-simulation (the fixed-frame response of
:func:`autobal.models.ross_rotor.simulate_fixed`).  The problem has the members the generic pipeline uses, so it is
transcribed, solved from its starts, ranked and continued from a coarse mesh by the same code as the Jeffcott
rotor's (:func:`autobal.ocp.solve.optimize`, which takes :func:`starts`, :func:`reference_level`,
:func:`resimulate`, :func:`rank_coarse` and HOLD_STATES from this module; :func:`autobal.ocp.transcription.transcribe`,
:class:`autobal.ocp.solve.Solver`, :func:`autobal.ocp.solve.refine`, :func:`autobal.ocp.simulation.simulate_profile`).

Every reported peak is the CVODES re-simulation of the physical (fixed-frame) response, max_t sqrt(x^2 + y^2).
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from autobal.analysis.fields import Record, TypedResult, declarations, quantity, record, unsaved
from autobal.analysis.figures import Figure, record_axis
from autobal.analysis.quantities import Quantity, convert
from autobal.analysis.result import new_figure, speed_axis, unit_axis
from autobal.analysis.standards import Margin, half_power_readings, margin_check, margin_quantities, margin_words
from autobal.models import ross_rotor as rr
from autobal.models.ross_rotor import POINTS_PER_REV, RESIM_TOL, ModalRotor, simulate_fixed
from autobal.ocp.drive_profile import drive_table
from autobal.ocp.problem import Dimensionless, PathConstraint
from autobal.ocp.search import SearchResult
from autobal.ocp.simulation import (
    DRIVE_QUANTITIES,
    DRIVE_TOL,
    acceleration_at,
    best_within_limits,
    drive_unreachable,
    drive_use,
    ramp_profile,
    ramp_runs,
    rate_cap,
    torque_reference,
)
from autobal.ocp.solve import AHEAD, MODELS, coarse_intervals, optimize
from autobal.ocp.solve import TIE as TIE_SOLVED
from autobal.ocp.transcription import DirectCollocation, mesh

EPS = 1e-3  # smoothing of |X^2 + Y^2| in the envelope, relative to the reference deflection


@dataclass
class ModalSpinupOcp(Dimensionless):
    """The spin-up problem of a reduced rotor, in SI at the boundary.

    Inside, as the generic pipeline (:mod:`autobal.ocp.transcription`, :mod:`autobal.ocp.solve`,
    :mod:`autobal.ocp.simulation`) takes every problem: time tau = omega_final t, speed nu = omega/omega_final,
    control u = alpha/alpha_max, and the members of :class:`autobal.ocp.problem.SpinupOcp` it uses (the state
    dimension and its speed, the equation, the named path constraints, the measure the epigraph bounds)."""

    rotor: ModalRotor
    omega_start: float  # rad/s
    omega_final: float  # rad/s
    horizon: float  # s, the deadline
    alpha_max: float  # rad/s^2
    nodes: tuple[int, ...]  # nodes whose deflection counts
    settling_time: float = 0.0  # s, held at omega_final after the deadline
    omega_max: float | None = None  # rad/s
    intervals: int = 160  # control intervals over the horizon
    degree: int = 3
    # (a, peak_scale2) of the nominal rotor when this is a perturbed one (:meth:`perturbed`): the scenarios of a
    # robust NLP share one epigraph level, so their states and envelopes share one scale
    scales: tuple[float, float] | None = None
    # "peak_deflection" (the epigraph r^2 <= S, minimise S) or "min_time" (free final time, up to ``horizon``, with
    # r <= deflection_limit at every collocation point), as the Jeffcott rotor's :class:`autobal.ocp.problem.SpinupOcp`
    objective: str = "peak_deflection"
    deflection_limit: float | None = None  # m, the largest deflection of the nodes of interest (0-peak)
    alpha_min: float | None = None  # rad/s^2, <= 0: alpha >= this (0: the speed never falls; None: -alpha_max)
    # the drive (as the Jeffcott problem's): the torque it needs is (J_rotor + drive_inertia) alpha, the rotor's
    # polar inertia from ROSS; the unbalance's reaction torque, of order m e r omega^2 (about 1e-4 N m on the shipped
    # rotor, against J alpha = 67 N m), is left out
    drive_inertia: float = 0.0  # kg m^2, the drive's own (motor rotor, coupling)
    torque_max: float | None = None  # N m
    braking_torque_max: float | None = None  # N m, -M <= this (0: no braking; None: up to torque_max)
    power_max: float | None = None  # W
    motor_stall_torque: float | None = None  # N m, L_s
    motor_no_load_speed: float | None = None  # rad/s, omega_nl

    # the problem as the generic pipeline sees it: alpha_min <= alpha <= alpha_max, no jerk terms, no drag
    n_extra = 1  # the epigraph level, or the final time over the horizon
    jerk_max = None
    jerk_penalty = 0.0
    jerk_variation = 0.0
    drag = 0.0  # N m s
    deflection_unit = "m"  # of deflection_limit and of every peak (the Jeffcott problem's: "1", delta/e)
    max_steps = 100000  # CVODES steps per call at most (the envelope of four modes whirls fast)
    p = ()  # the equation has no parameters: the rotor's matrices are in it

    def __post_init__(self):
        if abs(self.omega_final - self.omega_start) > self.alpha_max * self.horizon:
            raise ValueError(f"|alpha| <= {self.alpha_max:g} rad/s^2 cannot reach {self.omega_final:g} rad/s "
                             f"from {self.omega_start:g} rad/s within the horizon {self.horizon:g} s")
        if self.objective not in ("peak_deflection", "min_time"):
            raise ValueError("the modal problem's objective is peak_deflection or min_time")
        if self.objective == "min_time" and self.deflection_limit is None:
            raise ValueError("the min_time objective needs a deflection_limit (m)")
        if self.deflection_limit is not None and not self.deflection_limit > 0:
            raise ValueError("the deflection limit must be positive (m)")
        self.check_drive()
        why = drive_unreachable(self)
        if why:  # before any solve: the search and the NLP would run for minutes to find no arrival
            raise ValueError(why)
        for nd in self.nodes:
            self.rotor.node_rows(nd)

    @property
    def inertia(self) -> float:
        """What the drive accelerates, kg m^2: the rotor's polar inertia and the drive's own."""
        return self.rotor.polar_inertia + self.drive_inertia

    @property
    def h(self) -> float:
        """Control interval, s."""
        return self.horizon / self.intervals

    @property
    def settling_intervals(self) -> int:
        return int(np.ceil(self.settling_time / self.h - 1e-9)) if self.settling_time > 0 else 0

    @property
    def method(self) -> DirectCollocation:
        """Radau collocation of the problem's degree on its control intervals."""
        return DirectCollocation(self.intervals, self.degree, "radau")

    # the dimensionless data (:class:`autobal.ocp.problem.Dimensionless`) on the time scale tau = omega_final t
    @property
    def Om(self) -> float:
        return self.omega_final

    @property
    def nx(self) -> int:
        """The envelope state (Re p, Im p, Re q, Im q) of the n modes and the speed."""
        return 4 * self.rotor.n + 1

    @property
    def speed_index(self) -> int:
        return 4 * self.rotor.n

    @cached_property
    def amplitude_scale(self) -> float:
        """a: the largest steady modal amplitude |E(omega)| up to omega_final (scales the states)."""
        if self.scales is not None:
            return self.scales[0]
        w = np.linspace(0, self.omega_final, 400)
        return float(max(np.abs(self.rotor.steady_amplitude(x)).max() for x in w)) or 1.0

    @cached_property
    def _rhs(self) -> ca.Function:
        R, n, a, wf = self.rotor, self.rotor.n, self.amplitude_scale, self.omega_final
        x, ast, par = ca.SX.sym("x", 4 * n + 1), ca.SX.sym("a"), ca.SX.sym("p", 0)
        pr, pi, qr, qi, nu = x[:n], x[n:2 * n], x[2 * n:3 * n], x[3 * n:4 * n], x[4 * n]
        w, al = nu * wf, ast * wf**2
        fr, fi = R.force_amplitude(w, al)
        ode = R.ode()
        ddr = ode(a * pr, a * wf * qr, w, al, fr) / (a * wf)
        ddi = ode(a * pi, a * wf * qi, w, al, fi) / (a * wf)
        dx = ca.vertcat(wf * qr + w * pi, wf * qi - w * pr, ddr + w * qi, ddi - w * qr, al / wf)
        return ca.Function("envelope", [x, ast, par], [dx / wf])

    def rhs(self) -> ca.Function:
        """(x, a*, p) -> dx/dtau of the scaled envelope state x = (Re p, Im p, Re q, Im q, nu), p = P/a,
        q = Q/(a omega_f), nu = omega/omega_f, a* = alpha/omega_f^2 (the modal equation,
        :meth:`autobal.models.ross_rotor.ModalRotor.ode`, on the complex envelope)."""
        return self._rhs

    def dynamics(self) -> ca.Function:
        """(x, u, h) -> h dx/dtau over an interval of length h (tau)."""
        x, u, h = ca.SX.sym("x", self.nx), ca.SX.sym("u"), ca.SX.sym("h")
        return ca.Function("modal_f", [x, u, h], [h * self._rhs(x, u * self.a_max, ca.DM(0, 1))])

    def envelope_rhs(self) -> ca.Function:
        """(x, u) -> dx/dt (per second) of the scaled envelope state, u = alpha/alpha_max."""
        x, u = ca.SX.sym("x", self.nx), ca.SX.sym("u")
        return ca.Function("envelope_s", [x, u], [self.omega_final * self._rhs(x, u * self.a_max, ca.DM(0, 1))])

    @cached_property
    def _envelope2(self) -> ca.Function:
        n = self.rotor.n
        x = ca.SX.sym("x", 4 * n + 1)
        out = []
        for nd in self.nodes:
            Rw = ca.DM(self.rotor.node_rows(nd))
            Xr, Xi = Rw @ x[:n], Rw @ x[n:2 * n]  # (x, y) real and imaginary parts
            V2 = ca.sumsqr(Xr) + ca.sumsqr(Xi)
            Wr, Wi = ca.sumsqr(Xr) - ca.sumsqr(Xi), 2 * ca.dot(Xr, Xi)
            out.append(0.5 * (V2 + ca.sqrt(Wr**2 + Wi**2 + (EPS * self.peak_scale2) ** 2)))
        return ca.Function("envelope2", [x], [ca.vertcat(*out)])

    def envelope2(self) -> ca.Function:
        """x -> the squared deflection envelope of each node of interest over a^2 (smoothed)."""
        return self._envelope2

    def path_constraints(self, ref: float) -> list[PathConstraint]:
        """The epigraph r^2/(a^2 ref) <= S (minimum peak) and the limit r^2 <= deflection_limit^2 (when set) of every
        node of interest at every path point, and the drive's limits on its torque J alpha
        (:meth:`autobal.ocp.problem.Dimensionless.drive_constraints`)."""
        x, a, v = ca.SX.sym("x", self.nx), ca.SX.sym("a"), ca.SX.sym("v", 1)
        out = []

        def add(name, expr, lb, ub):
            out.append(PathConstraint(name, ca.Function(f"path{len(out)}", [x, a, v], [expr]), lb, ub,
                                      ca.depends_on(expr, a)))

        if self.objective == "peak_deflection":
            add("deflection epigraph r^2 <= S", self._envelope2(x) / ref - v[0], -ca.inf, 0.0)
        if self.deflection_limit is not None:
            lim2 = (self.deflection_limit / self.amplitude_scale) ** 2
            add(f"deflection limit r <= {self.deflection_limit:.6g} m", self._envelope2(x) / lim2, -ca.inf, 1.0)
        self.drive_constraints(self.inertia * a * self.Om**2, x[self.speed_index], add)
        return out

    def epigraph2(self, states: np.ndarray) -> np.ndarray:
        """The squared envelope over a^2 (the epigraph's measure) of the nodes of interest, largest node, at
        states (..., nx)."""
        X = np.reshape(states, (-1, self.nx))
        e2 = np.array(self._envelope2.map(X.shape[0])(X.T))
        return e2.max(axis=0).reshape(np.shape(states)[:-1])

    @property
    def epigraph_unit(self) -> float:
        """m per unit of the square root of the epigraph's measure (a)."""
        return self.amplitude_scale

    def deflection_of(self, states: np.ndarray) -> dict:
        """The largest node's deflection envelope at states (k, nx), for a failed solve's last iterate, m."""
        return {"deflection_envelope_m": list(np.sqrt(self.epigraph2(states)) * self.amplitude_scale)}

    @cached_property
    def peak_scale2(self) -> float:
        """(largest steady deflection of the nodes of interest / a)^2: the scale of the epigraph level."""
        if self.scales is not None:
            return self.scales[1]
        w = np.linspace(0, self.omega_final, 400)
        a = self.amplitude_scale
        return max(float(np.max(np.abs(self.rotor.node_rows(nd) @ self.rotor.steady_amplitude(x)))) / a
                   for nd in self.nodes for x in w) ** 2

    # the members the robust study uses (:mod:`autobal.ocp.robust`), as the Jeffcott problem's
    def perturbed(self, factors) -> ModalSpinupOcp:
        """The problem of the rotor with the factors (critical speed, damping, liquid mass) applied: the modal
        stiffness scaled by the critical-speed factor squared (every natural frequency by the factor), the modal
        damping by the damping factor; the scales of this problem kept (one epigraph for every scenario).  The
        modal rotor has no liquid: its factor must be 1."""
        cr, dmp, liq = (float(f) for f in factors)
        if liq != 1.0:
            raise ValueError("the modal rotor has no liquid block: its liquid-mass factor must be 1")
        R = self.rotor
        rotor = dataclasses.replace(R, K=R.K * cr**2, C=R.C * dmp, omega_n=R.omega_n * cr)
        return dataclasses.replace(self, rotor=rotor, scales=(self.amplitude_scale, self.peak_scale2))

    def on_intervals(self, n: int) -> ModalSpinupOcp:
        """The same problem on n control intervals of the horizon (a coarse stage of the mesh continuation),
        its scales kept."""
        if n == self.intervals:
            return self
        return dataclasses.replace(self, intervals=n, scales=(self.amplitude_scale, self.peak_scale2))

    def fast_peaks(self, U: np.ndarray) -> np.ndarray:
        """Peak deflection (m) of the profiles U (C, n control intervals of the horizon, alpha/alpha_max; n may
        be a coarse mesh's) by the Runge-Kutta screening (:func:`screen`)."""
        U = np.atleast_2d(U)
        return screen(self.on_intervals(U.shape[1]), U)

    def resimulated_peak(self, u: np.ndarray, h: np.ndarray, label: str, points: int = 8) -> float:
        """Peak deflection (m) of the profile u (alpha/alpha_max on the intervals of dimensionless length h, the
        horizon's then the settling window's), CVODES in the fixed frame (:func:`resimulate`; ``points`` is the
        problem's own)."""
        return resimulate(self, u, h, label).peak

    @property
    def q0(self) -> np.ndarray:
        """The steady envelope at omega_start (scaled)."""
        E = self.rotor.steady_amplitude(self.omega_start) / self.amplitude_scale
        Q = 1j * self.omega_start * E / self.omega_final
        return np.concatenate([E.real, E.imag, Q.real, Q.imag, [self.omega_start / self.omega_final]])


@dataclass
class ModalTrajectory:
    """A speed profile and the physical response (fixed frame) of the reduced rotor, SI."""

    label: str
    t: np.ndarray  # s
    omega: np.ndarray  # rad/s
    deflection: np.ndarray  # (len(nodes), len(t)) sqrt(x^2 + y^2), m
    nodes: tuple
    t_u: np.ndarray  # interval starts, s
    alpha: np.ndarray  # rad/s^2
    torque: np.ndarray  # N m at the samples t, J alpha (nan without the drive's inertia)
    peak: float = field(init=False)  # m
    t_peak: float = field(init=False)  # s
    node_of_peak: int = field(init=False)

    def __post_init__(self):
        i, k = np.unravel_index(np.argmax(self.deflection), self.deflection.shape)
        self.peak, self.t_peak, self.node_of_peak = float(self.deflection[i, k]), float(self.t[k]), self.nodes[i]

    def to_dict(self) -> dict:
        return {"label": self.label, "peak_deflection_m": self.peak, "time_of_peak_s": self.t_peak,
                "omega_at_peak_rad_s": float(np.interp(self.t_peak, self.t, self.omega)),
                "node_of_peak": int(self.node_of_peak)}


def resimulate(ocp: ModalSpinupOcp, u: np.ndarray, h: np.ndarray | None, label: str) -> ModalTrajectory:
    """CVODES re-simulation (fixed frame) of the control u (over alpha_max) on intervals of dimensionless length h
    (tau = omega_final t, as the generic pipeline's :func:`autobal.ocp.simulation.resimulate`; None: the problem's
    mesh, its control intervals then its settling intervals), settling window included."""
    u = np.asarray(u, float)
    if h is None:
        ms = mesh(ocp, ocp.intervals)
        h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])[:len(u)]
    hs = np.asarray(h, float) / ocp.Om  # s
    t, w, xy = simulate_fixed(ocp.rotor, ocp.omega_start, u * ocp.alpha_max, hs, ocp.nodes)
    t_u = np.concatenate([[0.0], np.cumsum(hs)[:-1]])
    alpha = u * ocp.alpha_max
    torque = ocp.inertia * acceleration_at(t, t_u, alpha) if ocp.inertia > 0 else np.full(t.shape, np.nan)
    return ModalTrajectory(label, t, w, np.hypot(xy[:, 0], xy[:, 1]), tuple(ocp.nodes), t_u, alpha, torque)


# ---- starts: a cheap global search over multi-phase speed profiles ------------------------------------

# the screening integrator: RK4 steps of at most RK4_STEP / (largest |eigenvalue| of the envelope equation), at
# least SAMPLES per control interval (on the shipped scene 20 per 50 ms: the peak within 1e-5 of 40 per interval
# and 0.3 % of CVODES; 10 per interval is unstable), the envelope sampled SAMPLES times per interval
RK4_STEP = 1.5  # |lambda| dt; RK4 is stable on the imaginary axis up to 2.83
SAMPLES = 10
KEEP = 2  # distinct search profiles solved by IPOPT
TIE = 2e-3  # relative: screened peaks this close tie (broken by the peak of the last phase)


@dataclass(frozen=True)
class LinearEnvelope:
    """The scaled envelope equation of :meth:`ModalSpinupOcp.envelope_rhs` as it is: affine in the modal
    part y of the state for a given speed and control, y' = (M0 + nu M1 + u M2) y + b0 + nu^2 b2 + u bu,
    nu' = u c.  Taken from the CasADi Function by differentiation (no second copy of the equation) and
    checked at a random point when built."""

    M: tuple  # M0, M1, M2 (m x m)
    b: tuple  # b0, b2, bu (m,)
    c: float  # nu' per unit u

    @classmethod
    def of(cls, ocp: ModalSpinupOcp) -> LinearEnvelope:
        f = ocp.envelope_rhs()
        nx = f.size1_in(0)
        m = nx - 1
        x, u = ca.SX.sym("x", nx), ca.SX.sym("u")
        fx = ca.Function("envelope_jacobian", [x, u], [ca.jacobian(f(x, u)[:m], x[:m])])

        def at(nu, uu, y=None):
            z = np.concatenate([np.zeros(m) if y is None else y, [nu]])
            return np.array(fx(z, uu)), np.array(f(z, uu)).ravel()

        (A0, b0), (A1, b1), (A2, b2) = at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0)
        lin = cls((A0, A1 - A0, A2 - A0), (b0[:m], b1[:m] - b0[:m], b2[:m] - b0[:m]), float(b2[m] - b0[m]))
        y = np.random.default_rng(0).standard_normal(m)
        _, exact = at(0.7, -0.4, y)
        if np.abs(lin.rhs(y[None], np.array([0.7]), np.array([-0.4]))[0] - exact[:m]).max() > 1e-9 * (
                1 + np.abs(exact).max()):
            raise ValueError("the screening integrator needs an envelope equation affine in the state")
        return lin

    def rhs(self, y: np.ndarray, nu: np.ndarray, u: np.ndarray) -> np.ndarray:
        (M0, M1, M2), (b0, b2, bu) = self.M, self.b
        return (y @ M0.T + nu[:, None] * (y @ M1.T) + u[:, None] * (y @ M2.T) + b0
                + (nu**2)[:, None] * b2 + u[:, None] * bu)


def screen(ocp: ModalSpinupOcp, u: np.ndarray, substeps: int | None = None, samples: int = SAMPLES,
           lin: LinearEnvelope | None = None, by_interval: bool = False) -> np.ndarray:
    """Peak deflection (m) of many control profiles at once: classical Runge-Kutta (fixed step) of the
    envelope equation on the control mesh, the deflection envelope (:meth:`ModalSpinupOcp.envelope2`)
    sampled ``samples`` times per interval.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    u : ndarray, shape (C, n)
        Acceleration over alpha_max on the n <= intervals + settling intervals control intervals of C
        candidates (zero after them).
    substeps : int, optional
        Runge-Kutta steps per interval (by default the fewest multiple of ``samples`` that keeps |lambda| dt
        below RK4_STEP).
    samples : int
        Envelope samples per interval (divides ``substeps``).
    by_interval : bool
        Return the largest deflection of every interval instead of the peak.

    Returns
    -------
    ndarray, shape (C,) or (C, intervals + settling intervals)
        Largest deflection over the nodes of interest (over the run or in each interval), m.
    """
    lin = lin or LinearEnvelope.of(ocp)
    env = ocp.envelope2()
    u = np.atleast_2d(u)
    Cn, n = u.shape
    K = ocp.intervals + ocp.settling_intervals
    u = np.concatenate([u, np.zeros((Cn, K - n))], axis=1)
    x0 = ocp.q0
    y, nu = np.tile(x0[:-1], (Cn, 1)), np.full(Cn, x0[-1])
    if substeps is None:
        top = (ocp.omega_max or ocp.omega_final) / ocp.omega_final
        rho = max(np.abs(np.linalg.eigvals(lin.M[0] + nu * lin.M[1] + a * lin.M[2])).max()
                  for nu in (0.0, top) for a in (-1.0, 1.0))
        substeps = samples * int(np.ceil(ocp.h * rho / RK4_STEP / samples))
    dt = ocp.h / substeps
    envm = env.map(Cn)
    best = np.zeros((Cn, K))
    for k in range(K):
        uk = u[:, k]
        dnu = uk * lin.c
        for s in range(substeps):
            k1 = lin.rhs(y, nu, uk)
            k2 = lin.rhs(y + 0.5 * dt * k1, nu + 0.5 * dt * dnu, uk)
            k3 = lin.rhs(y + 0.5 * dt * k2, nu + 0.5 * dt * dnu, uk)
            k4 = lin.rhs(y + dt * k3, nu + dt * dnu, uk)
            y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            nu = nu + dt * dnu
            if (s + 1) % (substeps // samples) == 0:
                r2 = np.array(envm(np.vstack([y.T, nu[None]])))
                best[:, k] = np.maximum(best[:, k], r2.max(axis=0))
    out = np.sqrt(best) * ocp.amplitude_scale
    return out if by_interval else out.max(axis=1)


def phase_profiles(ocp: ModalSpinupOcp, w1, u_b, d, w3) -> np.ndarray:
    """Controls (over alpha_max, averaged exactly onto the control intervals of the horizon) of the
    four-phase profiles: full acceleration to ``w1`` (rad/s), acceleration ``u_b`` alpha_max for ``d`` (s),
    full acceleration to ``w3`` (rad/s), then the constant acceleration that reaches omega_final at the
    deadline (``w3`` = omega_final: full acceleration and hold).

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem (speeds, alpha_max, horizon, control intervals).
    w1, u_b, d, w3 : array_like
        Speed at the end of the first phase (rad/s), acceleration of the middle phase over alpha_max, its
        duration (s), speed at the end of the third phase (rad/s); one profile per element.

    Returns
    -------
    ndarray, shape (profiles, intervals)
        alpha/alpha_max on each control interval of the horizon.
    """
    w1, u_b, d, w3 = (np.atleast_1d(np.asarray(v, float)) for v in (w1, u_b, d, w3))
    a, w0, wf, T = ocp.alpha_max, ocp.omega_start, ocp.omega_final, ocp.horizon
    t1 = (w1 - w0) / a
    w2 = w1 + u_b * a * d
    t3 = t1 + d + (w3 - w2) / a
    tk = np.arange(ocp.intervals + 1) * ocp.h
    out = np.empty((w1.size, tk.size - 1))
    for i in range(w1.size):
        bt = [0.0, t1[i], t1[i] + d[i], t3[i], T if w3[i] < wf else t3[i], T + 1.0]
        bw = [w0, w1[i], w2[i], w3[i], wf, wf]
        out[i] = np.diff(np.interp(tk, bt, bw)) / (ocp.h * a)
    return out


def grid_search(ocp: ModalSpinupOcp, n_w: int = 12, n_u: int = 4, n_d: int = 6, n_w3: int = 6,
                keep: int = KEEP) -> SearchResult:
    """Screen the four-phase family (:func:`phase_profiles`) on a grid: w1 between the start and the final
    speed or 1.25 x the first critical speed above the start (the passage of the first critical group), u_b in
    [u_min, 0.5] (u_min = -1 unless a minimum acceleration is set), d up to what the horizon leaves, w3 between
    the speed after the middle phase and omega_final; return the ``keep`` best whose first phases differ by more
    than a grid cell, the best first phase with each w3 that ties with it (the later passage is multimodal: they
    lead IPOPT to different optima); none when the horizon leaves no time for a middle phase.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    n_w, n_u, n_d, n_w3 : int
        Grid points of w1, u_b, d and w3.
    keep : int
        Distinct first phases returned.

    Returns
    -------
    SearchResult
        Parameters (w1 rad/s, u_b, d s, w3 rad/s) and screened peaks (m), best first.
    """
    w0, wf, a, T = ocp.omega_start, ocp.omega_final, ocp.alpha_max, ocp.horizon
    wc = [w for w in ocp.rotor.critical_speeds(wf)["wd"] if w > w0]
    top = min(wf, 1.25 * wc[0]) if wc else wf  # the first phase ends near the first critical speed above the start
    W1, UB, D, F3 = np.meshgrid(np.linspace(w0, top, n_w + 1)[1:], np.linspace(ocp.u_min, 0.5, n_u),
                                np.linspace(0, 1, n_d + 1)[1:], np.linspace(0, 1, n_w3 + 1)[1:], indexing="ij")
    W1, UB, D, F3 = W1.ravel(), UB.ravel(), D.ravel(), F3.ravel()
    slack = T - (wf - w0) / a
    D = D * slack / (1 - UB)  # the middle phase lasts at most what the horizon leaves
    W2 = W1 + UB * a * D
    W3 = W2 + F3 * (wf - W2)
    ok = (W2 >= 0) & (W2 <= wf) & (D > 0) & ((W1 - w0) / a + D + (wf - W2) / a <= T * (1 + 1e-9))
    if ocp.omega_max is not None:
        ok &= W1 <= ocp.omega_max
    W1, UB, D, W3 = W1[ok], UB[ok], D[ok], W3[ok]
    if not ok.any():
        return SearchResult(np.empty((0, 4)), np.empty(0), 0)
    U = phase_profiles(ocp, W1, UB, D, W3)
    E = screen(ocp, U, by_interval=True)
    peaks = E.max(axis=1)
    # the peak past the first passage (after the middle phase, above ``top``): the first passage usually sets
    # the peak, so profiles that differ in w3 only tie; among ties (TIE) the lower later peak wins
    K = E.shape[1]
    speed = np.concatenate([w0 + np.cumsum(U * a * ocp.h, axis=1) - U * a * ocp.h,
                            np.full((U.shape[0], K - U.shape[1]), wf)], axis=1)  # at each interval start
    t2 = (W1 - w0) / a + D
    past = (speed >= top) & (np.arange(K)[None, :] * ocp.h >= t2[:, None] - 1e-12)
    # to 1e-9 of the largest: the screening's rounding (its sums' order varies between runs with the BLAS threads)
    # must not reorder ties, so that a scene gives the same starts in every run
    late = np.round(np.where(past, E, 0.0).max(axis=1) / E.max(), 9)
    peaks = np.round(peaks / E.max(), 9) * E.max()
    cell = (top - w0) / n_w
    chosen = []
    free = np.ones(peaks.size, bool)
    picks = 0
    while picks < keep and free.any():
        low = peaks[free].min()
        pool = np.flatnonzero(free & (peaks <= low * (1 + TIE)))
        i = pool[np.argmin(late[pool])]
        if picks == 0:  # the best first phase with every w3 of the grid: the later passage is multimodal
            same = pool[(W1[pool] == W1[i]) & (UB[pool] == UB[i]) & (D[pool] == D[i])]
            chosen += list(same[np.argsort(late[same], kind="stable")])
        else:
            chosen.append(i)
        picks += 1
        free &= np.abs(W1 - W1[i]) > 1.5 * cell
    idx = np.array(chosen, int)
    return SearchResult(np.column_stack([W1[idx], UB[idx], D[idx], W3[idx]]), peaks[idx], int(ok.sum()))


def starts(ocp: ModalSpinupOcp, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
    """Initial profiles (the starts of :func:`autobal.ocp.solve.optimize`): the ``KEEP`` best four-phase profiles of
    the screening (:func:`grid_search`), then the constant ramp to the deadline and the maximum-acceleration ramp
    with hold unless the search's best is AHEAD below both of their (screened) peaks.  They are screened on the
    coarse mesh of the mesh continuation (:func:`autobal.ocp.solve.coarse_intervals` of n), where they are
    solved, and each of its intervals' values is repeated onto the n: on the shipped scene the screening on 160
    intervals takes 1.5 x the CPU time of 80 and orders the tied profiles otherwise.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    n : int
        Control intervals of the horizon.
    multistart : bool
        All starts; otherwise the first only.

    Returns
    -------
    list of (str, ndarray)
        Label and alpha/alpha_max on each of the n control intervals of the horizon.
    """
    nc = coarse_intervals(n)
    o = ocp.on_intervals(nc)
    const = abs(o.omega_final - o.omega_start) / o.horizon
    out = [("constant ramp", ramp_profile(o, nc, const)),
           ("maximum-acceleration ramp", ramp_profile(o, nc, o.alpha_max))]
    if o.omega_final > o.omega_start:
        found, a = grid_search(o), o.alpha_max
        search = [(f"search: {a:.3g} rad/s^2 to {p[0]:.4g} rad/s, {p[1] * a:.3g} rad/s^2 for {p[2]:.3g} s, {a:.3g} "
                   f"rad/s^2 to {p[3]:.4g} rad/s, then constant (screened peak {pk * 1e6:.4g} um)",
                   phase_profiles(o, *p)[0]) for p, pk in zip(found.params, found.peaks, strict=True)]
        ahead = found.peaks.size and screen(o, np.array([u for _, u in out])).min() * (1 - AHEAD) >= found.peaks[0]
        out = search + ([] if ahead else out)
    return [(label, np.repeat(u, n // nc)) for label, u in out[:None if multistart else 1]]


def baselines(ocp: ModalSpinupOcp) -> dict[str, ModalTrajectory]:
    """The constant ramp to the deadline and the maximum-acceleration ramp with hold, re-simulated; when the latter
    breaks a drive limit, the fastest ramp and hold within them (the drive's rate at the top speed,
    :func:`autobal.ocp.simulation.rate_cap`: exact, the torque being J alpha), if it is faster than the constant
    ramp."""
    const = abs(ocp.omega_final - ocp.omega_start) / ocp.horizon
    zeros = np.zeros(ocp.settling_intervals)

    def ramp(a: float, label: str) -> ModalTrajectory:
        return resimulate(ocp, np.concatenate([ramp_profile(ocp, ocp.intervals, a), zeros]), None, label)

    out = {"constant_ramp": ramp(const, f"constant ramp {const:.4g} rad/s^2"),
           "max_acceleration_ramp": ramp(ocp.alpha_max, f"ramp {ocp.alpha_max:.4g} rad/s^2 and hold")}
    a = rate_cap(ocp, max(ocp.omega_start, ocp.omega_final))
    if drive_use(ocp, out["max_acceleration_ramp"])["within_drive_limits"] is False and a > const:
        out["feasible_ramp"] = ramp(a, f"ramp {a:.4g} rad/s^2 and hold (fastest within the drive limits)")
    return out


# the coarse solves of the starts begin with the collocation states simulated from the profile (the shipped scene's
# optimum was found so; the Jeffcott rotor's begin held, :data:`autobal.ocp.solve.HOLD_STATES`)
HOLD_STATES = False


def reference_level(ocp: ModalSpinupOcp) -> float:
    """The scale of the epigraph level: the largest steady deflection squared
    (:attr:`ModalSpinupOcp.peak_scale2`); 1 for min_time."""
    return ocp.peak_scale2 if ocp.objective == "peak_deflection" else 1.0


def rank_coarse(ocp: ModalSpinupOcp, found: list, n: int) -> tuple[int, dict[int, float]]:
    """The best of the coarse optima ``found`` ((label, solution) pairs, in start order) by the peak of its CVODES
    re-simulation (:func:`resimulate`; ties within :data:`autobal.ocp.solve.TIE` go to the earlier start): its
    index and every re-simulated peak (m) by index."""
    peaks = {i: resimulate(ocp, sol.u, sol.h, "coarse").peak for i, (_, sol) in enumerate(found)}
    best = 0
    for i, pk in peaks.items():
        if pk < peaks[best] * (1 - TIE_SOLVED):
            best = i
    return best, peaks


MODELS[ModalSpinupOcp] = sys.modules[__name__]  # the parts above are this problem's in the shared loop


# ---- the study of a scene: reduction, critical speeds vs ROSS, optimum vs ramps ------------------------

def _node():
    return quantity("1", "", "node of the shaft model")


def _peak(description: str, headline: int = 0):
    return quantity("m", "r*", description, "µm", headline=headline)


@record
class ModalBaseline(Record):
    """A constant-ramp baseline of the modal rotor, re-simulated, and its drive use."""

    label: str
    peak_deflection_m: float = _peak("peak deflection of a ramp baseline")
    time_of_peak_s: float = quantity("s", "t*", "time of a ramp baseline's peak")
    omega_at_peak_rad_s: float = quantity("rad/s", "ω*", "speed at a ramp baseline's peak")
    node_of_peak: int = _node()
    max_torque_N_m: float | None = quantity("N*m", "M", "largest and smallest drive torque of a ramp baseline")
    min_torque_N_m: float | None = quantity("N*m", "M", "largest and smallest drive torque of a ramp baseline")
    max_power_W: float | None = quantity("W", "P", "largest drive power of a ramp baseline", "kW")
    within_drive_limits: bool | None
    violated: list[str]


@record
class Unbalance(Record):
    node: int = _node()
    magnitude_kg_m: float = quantity("kg*m", "m e", "unbalance", "g·mm")
    phase_rad: float = quantity("rad", "φ", "phase of the unbalance")


def _critical():
    return quantity("rad/s", "ω_c", "critical speeds below the final speed: reduced model, ROSS")


def _damping():
    return quantity("1", "ζ", "damping ratio of each critical speed's mode: reduced model, ROSS")


@record
class CriticalSpeeds(Record):
    """The reduced model's critical speeds below the final speed with their API 684 margins, and ROSS's (None: not
    compared)."""

    reduced_wd_rad_s: list[float] = _critical()
    reduced_damping_ratio: list[float] = _damping()
    margins: list[Margin]
    ross_wd_rad_s: list[float] | None = _critical()
    ross_damping_ratio: list[float] | None = _damping()
    max_rel_error_vs_ross: float | None = quantity("1", "", "largest critical-speed difference from ROSS", headline=7)


def _time():
    return quantity("s", "", "times: final solve, search for starts")


def _frequency():
    return quantity("rad/s", "ω_n", "undamped natural frequencies of the kept modes, the cutoff, the lowest left out")


def _inertia():
    return quantity("kg*m^2", "J", "polar inertia the drive accelerates (rotor and drive); the rotor's, from ROSS's "
                                   "mass matrix")


_NO_INERTIA = "the rotor and its drive have no polar inertia: the drive torque is not known"
_NO_RAMP = "no ramp keeps the drive limits (each is labelled outside them): no gain is quoted"
_NOT_COMPARED = "not compared with ROSS (validate_with_ross: false)"


@record
class ModalSpinupResult(TypedResult):
    """The optimal spin-up of a reduced ROSS rotor beside the constant ramps (every peak re-simulated), with the
    reduced model's critical speeds beside ROSS's own: deflections in m (the largest radius of the whirl orbit over
    the nodes of interest, 0-peak), speeds in rad/s.  The run also holds the re-simulations and the Campbell diagram
    its figures draw (None in a Result loaded from results.json)."""

    title: str
    objective: str
    method: str
    status: str
    ipopt_iterations: int = quantity("1", "", "iterations of the final solve")
    solve_time_s: float = _time()
    build_time_s: float = quantity("s", "", "build time")
    search_time_s: float = _time()
    total_solve_time_s: float = quantity("s", "", "solve time (all starts)")
    peak_deflection_m: float = _peak("peak deflection of the optimum, 0-peak (re-simulated)", 1)
    collocation_peak_m: float = _peak("peak deflection of the collocation / of a start's optimum, re-simulated")
    resimulation_rel_error: float = quantity("1", "", "relative difference, CVODES re-simulation vs collocation")
    node_of_peak: int = quantity("1", "", "node of the peak")
    time_of_peak_s: float = quantity("s", "t*", "time of the peak", headline=4)
    omega_at_peak_rad_s: float = quantity("rad/s", "ω*", "speed at the peak", headline=5)
    baseline_ramp_peak_m: float | None = _peak("peak deflection of the best ramp within the drive limits", 2)
    baseline_ramp_key: str | None
    improvement_over_best_ramp: float | None = quantity("1", "", "improvement over that ramp, 1 − r*/r*_ramp",
                                                        headline=3)
    #: one row per NLP solve of the multi-start (its keys by stage: the solver's log)
    starts: list[dict]
    baselines: dict[str, ModalBaseline]
    max_torque_N_m: float | None  # DRIVE_QUANTITIES
    min_torque_N_m: float | None
    max_power_W: float | None
    within_drive_limits: bool | None
    violated: list[str]
    drive_polar_inertia_kg_m2: float = _inertia()
    rotor_polar_inertia_kg_m2: float = _inertia()
    torque_limit_N_m: float | None
    power_limit_W: float | None
    braking_torque_limit_N_m: float | None
    max_deceleration_rad_s2: float = quantity("rad/s^2", "−α_min", "largest deceleration the drive allows")
    brakes: bool | None
    modes: int = quantity("1", "", "modes kept")
    natural_frequencies_rad_s: list[float] = _frequency()
    mode_cutoff_rad_s: float = quantity("rad/s", "ω_c", "mode cutoff")
    lowest_dropped_natural_frequency_rad_s: float | None = _frequency()
    gyroscopic: bool
    gyroscopic_shift: float = quantity("1", "", "largest relative shift of a critical speed by the gyroscopic terms")
    unbalance: list[Unbalance]
    critical_speeds: CriticalSpeeds
    accuracy: dict
    final_speed_rad_s: float = quantity("rad/s", "ω_f", "final (service) speed", headline=6)
    optimum: ModalTrajectory | None = unsaved()
    ramp_runs: dict | None = unsaved()  # baseline key -> its ModalTrajectory
    campbell: dict | None = unsaved()  # "omega" (rad/s), "wd" (rad/s, speeds x modes) of the reduced model
    name = "ross_spinup"
    null_reasons = {"ross_wd_rad_s": _NOT_COMPARED, "ross_damping_ratio": _NOT_COMPARED,
                    "max_rel_error_vs_ross": _NOT_COMPARED,
                    "lowest_dropped_natural_frequency_rad_s": "no mode was left out: all lateral modes are below the "
                                                              "cutoff",
                    **dict.fromkeys(("baseline_ramp_peak_m", "baseline_ramp_key", "improvement_over_best_ramp"),
                                    _NO_RAMP),
                    **dict.fromkeys(("max_torque_N_m", "min_torque_N_m", "max_power_W", "within_drive_limits",
                                     "brakes"), _NO_INERTIA),
                    "torque_limit_N_m": "no torque limit in the scene", "power_limit_W": "no power limit in the scene",
                    "braking_torque_limit_N_m": "no braking-torque limit in the scene"}

    @property
    def peak_deflection(self) -> float:
        """Re-simulated peak deflection of the optimum over the nodes of interest, m."""
        return self.peak_deflection_m

    @property
    def best_ramp_peak(self) -> float:
        """Re-simulated peak deflection of the better constant ramp, m."""
        return self.baseline_ramp_peak_m

    @property
    def critical_speed_rel_error(self) -> float | None:
        """Largest relative difference between the reduced model's critical speeds and ROSS's (None unchecked)."""
        return self.critical_speeds.max_rel_error_vs_ross

    @property
    def final_speed(self) -> float:
        """The final (service) speed, rad/s: where the optimum ends."""
        return self.final_speed_rad_s

    def verdict(self) -> tuple[bool | None, str]:
        """The optimum's peak deflection (0-peak) against the best ramp within the drive limits (the only reference a
        gain is quoted against), whether it brakes and keeps the drive limits; the NLP status first when it failed."""
        q = QUANTITIES.find
        words = f"peak deflection {q('peak_deflection_m').text(self.peak_deflection_m)} 0-peak at node " \
                f"{self.node_of_peak}"
        gain = self.improvement_over_best_ramp
        if gain is not None:
            words += (f", {-100 * gain:+.1f} % against the best ramp within the drive limits "
                      f"({q('baseline_ramp_peak_m').text(self.baseline_ramp_peak_m)})")
        else:
            words += ", no ramp keeps the drive limits: no gain is quoted"
        if self.brakes is not None:
            words += (f"; it brakes (smallest torque {q('min_torque_N_m').text(self.min_torque_N_m)})" if self.brakes
                      else "; it does not brake")
        ok = gain is None or gain >= -1e-4
        if self.within_drive_limits is False:
            ok, words = False, words + f"; drive limits EXCEEDED ({', '.join(self.violated or [])})"
        if self.status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
            ok, words = False, f"NLP solver {self.status}: " + words
        return ok, words

    def summary(self) -> str:
        cs, q = self.critical_speeds, QUANTITIES.find
        ok, words = self.verdict()
        ross = cs.ross_wd_rad_s
        speed = q("critical_speeds.reduced_wd_rad_s")
        lines = [f"multi-mode spin-up: {'ok' if ok else 'NOT OK'}: {words}", *self.quantities.lines(self.to_dict()),
                 f"  {self.modes} modes up to {q('mode_cutoff_rad_s').text(self.mode_cutoff_rad_s)}, gyroscopic "
                 f"terms {'kept' if self.gyroscopic else 'dropped'} (they move a critical speed by "
                 f"{100 * self.gyroscopic_shift:.3g} %)",
                 "  critical speeds below the final speed (reduced model; API 684 (2005): amplification factor at "
                 "the half-power points of the unbalance response at the nodes of interest, separation margin from "
                 "the final (service) speed):"]
        for i, w in enumerate(cs.reduced_wd_rad_s):
            lines.append(f"    {speed.text(w)}: {margin_words(cs.margins[i].to_dict())}"
                         + ("" if ross is None or i >= len(ross) else f"; ROSS {speed.text(ross[i])}"))
        if ross is not None:
            lines.append(f"  largest difference of the reduced model's critical speeds from ROSS's: "
                         f"{100 * cs.max_rel_error_vs_ross:.3f} %")
        lines.append(f"  NLP: {self.status}, {self.ipopt_iterations} IPOPT iterations, {self.solve_time_s:.2f} s "
                     f"(build {self.build_time_s:.2f} s, search for starts {self.search_time_s:.2f} s); collocation "
                     f"peak {q('collocation_peak_m').text(self.collocation_peak_m)} (difference "
                     f"{self.resimulation_rel_error:.2e})")
        for k, v in self.baselines.items():
            lim = " (outside the drive limits: " + ", ".join(v.violated) + ")" if v.within_drive_limits is False \
                else ""
            lines.append(f"  {v.label:40s} peak {q('peak_deflection_m').text(v.peak_deflection_m)} at node "
                         f"{v.node_of_peak}{lim}" + (" [reference]" if k == self.baseline_ramp_key else ""))
        return "\n".join(lines)

    def _held(self):
        if self.optimum is None:
            raise ValueError(f"{self.name}: a Result loaded from results.json holds no re-simulations; its tables and "
                             "figures are the files of its run")

    def tables(self) -> dict[str, dict]:
        self._held()
        o, cs = self.optimum, self.critical_speeds
        cols = {}
        for k, v in self.ramp_runs.items():
            cols |= {f"{k}_t_s": v.t, f"{k}_omega_rad_s": v.omega, f"{k}_deflection_m": v.deflection.max(axis=0)}
        n = min(len(c) for c in cols.values())
        out = {"ross_spinup_optimum.csv": {"t_s": o.t, "omega_rad_s": o.omega,
                                           "omega_rpm": convert(o.omega, "rad/s", "rpm")} | {
                   f"deflection_node{nd}_m": o.deflection[i] for i, nd in enumerate(o.nodes)},
               "ross_spinup_controls.csv": {"t_start_s": o.t_u, "alpha_rad_s2": o.alpha},
               "drive_profile.csv": drive_table(o),
               "ross_spinup_baselines.csv": {k: np.asarray(v)[:n] for k, v in cols.items()},
               "ross_modes.csv": {"mode": np.arange(1, self.modes + 1),
                                  "natural_frequency_rad_s": self.natural_frequencies_rad_s}}
        m = len(cs.reduced_wd_rad_s)
        ross = cs.ross_wd_rad_s
        out["ross_critical_speeds.csv"] = {"reduced_wd_rad_s": cs.reduced_wd_rad_s,
                                           "reduced_damping_ratio": cs.reduced_damping_ratio,
                                           "ross_wd_rad_s": (ross[:m] + [np.nan] * (m - len(ross))) if ross is not None
                                           else [np.nan] * m}
        return out

    def _runs(self):
        self._held()
        uses = {k: {"within_drive_limits": b.within_drive_limits} for k, b in self.baselines.items()}
        return [(self.optimum, "C3", "-", 1.4, "optimum"), *ramp_runs(self.ramp_runs, uses)]

    def _criticals(self, ax, vertical: bool, factor: float) -> None:
        for i, w in enumerate(self.critical_speeds.reduced_wd_rad_s):
            (ax.axvline if vertical else ax.axhline)(w * factor, color="k", lw=0.6, ls=":",
                                                     label="critical speeds (reduced model)" if i == 0 else None)

    def draw(self, ax) -> None:
        """Largest deflection over the nodes of interest against speed, optimum and ramps (the declared display unit,
        µm; the speed in rpm, rad/s on top)."""
        q = QUANTITIES.find("peak_deflection_m")
        fw = speed_axis(ax, "x")
        for tr, c, ls, lw, lab in self._runs():
            ax.plot(tr.omega * fw, q.shown(tr.deflection.max(axis=0)), color=c, ls=ls, lw=lw,
                    label=f"{lab} (peak {q.text(tr.peak)})")
        self._criticals(ax, True, fw)
        ax.set_ylabel(rf"deflection $\max_{{nodes}}\sqrt{{x^2+y^2}}$, {q.display} 0-peak")
        record_axis(ax, "y", q.unit, q.display)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict[str, Figure]:
        """Speed (rpm, rad/s) and acceleration (rad/s², rpm/s) against time; deflection (µm) against time and speed;
        Campbell diagram (rad/s, rpm and Hz); every axis in its display unit."""
        title, q = self.title, QUANTITIES.find("peak_deflection_m")
        fig, axes = new_figure((8, 6), 2, 1, sharex=True)
        ft = unit_axis(axes[1], "time t", "s", which="x")
        fw, fa = speed_axis(axes[0]), unit_axis(axes[1], r"acceleration $\alpha$", "rad/s^2")
        for tr, c, ls, lw, lab in self._runs():
            axes[0].plot(tr.t * ft, tr.omega * fw, color=c, ls=ls, lw=lw, label=lab)
            axes[1].plot(np.append(tr.t_u, tr.t[-1]) * ft, np.append(tr.alpha, tr.alpha[-1]) * fa,
                         drawstyle="steps-post", color=c, ls=ls, lw=lw)
        self._criticals(axes[0], False, fw)
        for ax in axes:
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(title, fontsize=9)

        fig2, (a1, a2) = new_figure((8, 7), 2, 1)
        ft = unit_axis(a1, "time t", "s", which="x")
        for tr, c, ls, lw, _ in self._runs():
            a1.plot(tr.t * ft, q.shown(tr.deflection.max(axis=0)), color=c, ls=ls, lw=lw)
        a1.set_ylabel(f"deflection, {q.display} 0-peak")
        record_axis(a1, "y", q.unit, q.display)
        a1.grid(alpha=0.3)
        self.draw(a2)
        fig2.suptitle(title, fontsize=9)

        fig3, ax = new_figure((7, 5))
        cb, cs = self.campbell, self.critical_speeds
        fw = speed_axis(ax, "x")
        ff = unit_axis(ax, "frequency", "rad/s", "Hz", other="rad/s")
        for k in range(cb["wd"].shape[1]):
            ax.plot(cb["omega"] * fw, cb["wd"][:, k] * ff, color="C0", lw=1.0,
                    label="damped natural frequencies (reduced)" if k == 0 else None)
        ax.plot(cb["omega"] * fw, cb["omega"] * ff, color="k", lw=0.8, label="synchronous line")
        ax.plot(np.asarray(cs.reduced_wd_rad_s) * fw, np.asarray(cs.reduced_wd_rad_s) * ff, "o", mfc="none",
                color="C3", label="critical speeds (reduced)")
        if cs.ross_wd_rad_s is not None:
            ax.plot(np.asarray(cs.ross_wd_rad_s) * fw, np.asarray(cs.ross_wd_rad_s) * ff, "x", color="k",
                    label="critical speeds (ROSS)")
        ax.set_ylim(0, 1.2 * cb["omega"][-1] * ff)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title("Campbell diagram of the reduced rotor", fontsize=9)
        what = "of the optimum beside the ramps, critical speeds of the reduced model dotted"
        return {"ross_spinup_profiles.png": Figure(fig, f"Multi-mode spin-up: speed and acceleration against time "
                                                        f"{what}"),
                "ross_spinup_deflection.png": Figure(fig2, "Multi-mode spin-up: deflection (largest over the nodes) "
                                                           f"against time and against speed {what}"),
                "ross_campbell.png": Figure(fig3, "Campbell diagram of the reduced rotor: damped natural frequencies "
                                                  "against speed, critical speeds of the reduced model (o) and of "
                                                  "ROSS (x)")}


#: every number of the ross_spinup block, from the fields: deflections in m (the largest radius of the whirl orbit
#: over the nodes of interest, 0-peak), speeds in rad/s; the drive's use of the optimum and the API 684 margins
#: (declared where they are computed) and the solver log of the starts as extra declarations
ModalSpinupResult.quantities = QUANTITIES = declarations(
    ModalSpinupResult, *DRIVE_QUANTITIES, *margin_quantities("critical_speeds.margins[]."),
    Quantity("starts[].objective starts[].resimulated_peak_m", "m", "r*", "peak deflection of a start's optimum, "
             "re-simulated", "µm"),
    Quantity("starts[].iterations", "1", "", "iterations of a start's solve"),
    Quantity("starts[].solve_time_s starts[].build_time_s", "s", "", "a start's solve and build time"))


def steady_deflection(ocp: ModalSpinupOcp, omega) -> np.ndarray:
    """The steady unbalance response at constant speeds ``omega`` (rad/s): the largest deflection envelope over the
    nodes of interest (the major half-axis of each node's orbit, :meth:`ModalSpinupOcp.epigraph2`) of the steady modal
    amplitude (:meth:`autobal.models.ross_rotor.ModalRotor.steady_amplitude`), m."""
    omega = np.atleast_1d(np.asarray(omega, float))
    a, n = ocp.amplitude_scale, ocp.rotor.n
    E = np.array([ocp.rotor.steady_amplitude(w) for w in omega]) / a
    X = np.hstack([E.real, E.imag, np.zeros((omega.size, 2 * n)), omega[:, None] / ocp.omega_final])
    return np.sqrt(ocp.epigraph2(X)) * a


def api_readings(ocp: ModalSpinupOcp, cs: dict) -> list:
    """Each critical speed of the reduced model (``cs``, :meth:`~autobal.models.ross_rotor.ModalRotor.critical_speeds`)
    read off the steady unbalance response at the nodes of interest (:func:`steady_deflection`) up to the mode cutoff
    (:func:`autobal.analysis.standards.half_power_readings`, API 684 (2005): AF at the half-power points)."""
    return half_power_readings(lambda w: steady_deflection(ocp, w), cs["wd"], high=ocp.rotor.cutoff_rad_s,
                               undamped=[z <= 0 for z in cs["damping_ratio"]])


def run(rotor: ModalRotor, ocp_kw: dict, title: str = "", ross_critical: dict | None = None,
        options: dict | None = None) -> ModalSpinupResult:
    """Optimise the spin-up of the reduced rotor (multi-start), re-simulate, compare with the ramps.

    Parameters
    ----------
    rotor : ModalRotor
        The reduced rotor (:func:`autobal.models.ross_rotor.reduce`).
    ocp_kw : dict
        Keyword arguments of :class:`ModalSpinupOcp` (SI: rad/s, rad/s^2, s).
    title : str
        For the figures.
    ross_critical : dict, optional
        ROSS's own critical speeds (:func:`autobal.models.ross_rotor.ross_critical_speeds`).
    options : dict, optional
        IPOPT options.

    Returns
    -------
    ModalSpinupResult
        Peaks in m, times in s, speeds in rad/s.
    """
    ocp = ModalSpinupOcp(rotor, **ocp_kw)
    opt = optimize(ocp, ocp.method, options=options)
    base = baselines(ocp)
    sol, tr = opt.solution, opt.trajectory
    cs = rotor.critical_speeds(ocp.omega_final)
    ross = None if ross_critical is None else list(ross_critical["wd"])
    use = {k: drive_use(ocp, v) for k, v in base.items()}
    ref_key = best_within_limits({k: v.peak for k, v in base.items()}, use)  # a gain only against these
    ref = base[ref_key].peak if ref_key else None
    opt_use = drive_use(ocp, tr)
    margins = [Margin(**margin_check(r, ocp.omega_final)) for r in api_readings(ocp, cs)]
    return ModalSpinupResult(
        title, "peak deflection over the nodes " + ", ".join(map(str, ocp.nodes)),
        f"Radau collocation (degree {ocp.degree}, {ocp.intervals} intervals + {ocp.settling_intervals} settling) of "
        "the complex envelope, structured derivatives; starts from a screened grid of four-phase profiles",
        sol.status, sol.iterations, sol.solve_time_s, opt.build_time_s, opt.times["global_search"],
        sum(r.get("solve_time_s", 0.0) for r in opt.starts), tr.peak, sol.peak_collocation,
        opt.resimulation_rel_error, tr.node_of_peak, tr.t_peak, float(np.interp(tr.t_peak, tr.t, tr.omega)), ref,
        ref_key, None if ref is None else 1 - tr.peak / ref, opt.starts,
        {k: ModalBaseline(v.label, v.peak, v.t_peak, float(np.interp(v.t_peak, v.t, v.omega)), int(v.node_of_peak),
                          **use[k]) for k, v in base.items()},
        **opt_use, drive_polar_inertia_kg_m2=ocp.inertia, rotor_polar_inertia_kg_m2=rotor.polar_inertia,
        torque_limit_N_m=ocp.torque_max, power_limit_W=ocp.power_max,
        braking_torque_limit_N_m=-ocp.torque_bounds[0] if np.isfinite(ocp.torque_bounds[0]) else None,
        max_deceleration_rad_s2=-ocp.u_min * ocp.alpha_max,
        brakes=None if opt_use["min_torque_N_m"] is None else
        bool(opt_use["min_torque_N_m"] < -DRIVE_TOL * torque_reference(ocp)),
        modes=rotor.n, natural_frequencies_rad_s=list(rotor.omega_n), mode_cutoff_rad_s=rotor.cutoff_rad_s,
        lowest_dropped_natural_frequency_rad_s=rotor.dropped_omega_n, gyroscopic=rotor.gyroscopic,
        gyroscopic_shift=rotor.gyroscopic_shift,
        unbalance=[Unbalance(u.node, u.magnitude, u.phase) for u in rotor.unbalances],
        critical_speeds=CriticalSpeeds(
            list(cs["wd"]), list(cs["damping_ratio"]), margins, ross,
            None if ross_critical is None else list(ross_critical["damping_ratio"]),
            rr.compare_critical_speeds(cs["wd"], ross_critical and ross_critical["wd"])),
        accuracy={"estimate": opt.resimulation_rel_error,
                  "how": "relative difference between the collocation's peak envelope and the CVODES re-simulation "
                         f"of the physical response (rtol {RESIM_TOL:g}, {POINTS_PER_REV} samples per revolution)"},
        final_speed_rad_s=float(tr.omega[-1]), optimum=tr, ramp_runs=base,
        campbell=rotor.campbell(1.2 * ocp.omega_final))
