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
collocation point, minimise S; or r^2 <= deflection_limit^2 there) and the physical re-simulation (the fixed-frame
response of :func:`autobal.models.ross_rotor.simulate_fixed`).  The problem implements the spin-up model protocol
(:class:`autobal.ocp.protocol.SpinupProblem`), so it is transcribed, solved from its starts (the screened four-phase
profiles of :mod:`autobal.ocp.modal_search`), ranked and continued from a coarse mesh by the same code as the
Jeffcott rotor's (:func:`autobal.ocp.solve.optimize`).  The study of a scene is :mod:`autobal.ocp.modal_study`.

Every reported peak is the CVODES re-simulation of the physical (fixed-frame) response, max_t sqrt(x^2 + y^2).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from autobal.models.ross_rotor import ModalRotor, simulate_fixed
from autobal.ocp.modal_search import screen
from autobal.ocp.modal_search import starts as search_starts
from autobal.ocp.problem import Dimensionless, PathConstraint
from autobal.ocp.simulation import (
    acceleration_at,
    drive_unreachable,
    drive_use,
    ramp_profile,
    rate_cap,
)
from autobal.ocp.solve import TIE
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
    # the coarse solves of the starts begin with the collocation states simulated from the profile (the shipped
    # scene's optimum was found so; the Jeffcott rotor's begin held)
    hold_states = False

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

    # the solver's parts of this model (:class:`autobal.ocp.protocol.SpinupProblem`)
    def deflection2(self) -> ca.Function:
        """x -> the squared deflection envelope of the largest node of interest over a^2 (smoothed): what an
        integrated objective would integrate (this problem's objectives bound it instead)."""
        x = ca.SX.sym("x", self.nx)
        return ca.Function("deflection2", [x], [ca.mmax(self._envelope2(x))])

    def starts(self, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
        """The screened four-phase profiles and the ramps on n control intervals
        (:func:`autobal.ocp.modal_search.starts`)."""
        return search_starts(self, n, multistart)

    def reference_level(self) -> float:
        """The scale of the epigraph level: the largest steady deflection squared (:attr:`peak_scale2`); 1 for
        min_time."""
        return self.peak_scale2 if self.objective == "peak_deflection" else 1.0

    def resimulate(self, u: np.ndarray, h: np.ndarray | None, label: str) -> ModalTrajectory:
        """CVODES re-simulation in the fixed frame (:func:`resimulate`): ``peak`` in m."""
        return resimulate(self, u, h, label)

    def rank_coarse(self, found: list, n: int) -> tuple[int, dict[int, float]]:
        """The best of the coarse optima ``found`` ((label, solution) pairs, in start order) by the peak of its CVODES
        re-simulation (:func:`resimulate`; ties within :data:`autobal.ocp.solve.TIE` go to the earlier start): its
        index and every re-simulated peak (m) by index."""
        peaks = {i: resimulate(self, sol.u, sol.h, "coarse").peak for i, (_, sol) in enumerate(found)}
        best = 0
        for i, pk in peaks.items():
            if pk < peaks[best] * (1 - TIE):
                best = i
        return best, peaks


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
        h = ms.lengths[:len(u)]
    hs = np.asarray(h, float) / ocp.Om  # s
    t, w, xy = simulate_fixed(ocp.rotor, ocp.omega_start, u * ocp.alpha_max, hs, ocp.nodes)
    t_u = np.concatenate([[0.0], np.cumsum(hs)[:-1]])
    alpha = u * ocp.alpha_max
    torque = ocp.inertia * acceleration_at(t, t_u, alpha) if ocp.inertia > 0 else np.full(t.shape, np.nan)
    return ModalTrajectory(label, t, w, np.hypot(xy[:, 0], xy[:, 1]), tuple(ocp.nodes), t_u, alpha, torque)


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
