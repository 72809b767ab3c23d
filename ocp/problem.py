"""Declaration of the spin-up problem (rockit's ``Ocp`` role): states, control, dynamics, named path
constraints, boundary conditions and objective, in SI at the boundary and in the dimensionless form
of Pashkov (2010), Eq. (2) inside.

Variables: time tau = Omega0 t (the critical period is 2 pi/sqrt(psi) in tau), deflection over e,
speed nu = omega/Omega0; the control is the angular acceleration over its limit,
u = alpha/alpha_max in [-1, 1], piecewise constant per interval.  State q = (x, y, x', y', nu) in
the frame rotating with the unbalance; the system starts from the steady state at omega_start
(rest when omega_start = 0) and reaches omega_final at the horizon (the deadline), then holds it
over the settling window, over which the peak still counts.

Objectives: ``peak_deflection`` (epigraph: delta^2 <= S at every collocation point, minimise S),
``peak_unbalance`` (the same with the system unbalance d), ``integrated_deflection`` (integral of
delta^2 over the horizon and the settling window), ``min_time`` (free final time subject to
delta <= deflection_limit).  Limits: |alpha| <= alpha_max, 0 <= omega <= omega_max, |M| <= M_max,
M omega <= P_max, braking -M <= B_max (0: none) and alpha >= alpha_min,
the motor characteristic M <= L_s (1 - omega/omega_nl), and optionally the jerk
|d alpha/dt| <= jerk_max between intervals; a jerk penalty (weight ``jerk_penalty`` on the sum of
squared changes, or ``jerk_variation`` on the smoothed total variation of alpha/alpha_max) regularises
the profile where the peak does not fix it.  By default the total variation is weighted 1e-4: a
minimum-peak optimum is flat in many directions (the controls after the peak, the area rather than the
shape of a short back-off), and unregularised it puts one-interval pulses there (chattering, measured by
:func:`pulse_variation`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from autobal.analysis.numerics.rotor import steady_q, unbalance
from autobal.models.rotor import STATES, RotorParams, rotor_model

OBJECTIVES = ("peak_deflection", "peak_unbalance", "integrated_deflection", "min_time")
# default weight of the smoothed total variation of alpha/alpha_max: removes the one-interval pulses of the
# minimum-peak optimum and changes its re-simulated peak by < 0.05 % on the shipped scenes (measured in
# docs/dev/spinup.md, "Drivable controls: the regulariser study")
JERK_VARIATION = 1e-4
# a posed spin-up passes near the critical speed (the top speed at least 1/CRITICAL_RATIO of it) within at most
# MAX_PERIODS natural periods of the rotor (horizon and settling window): beyond, CVODES cannot follow the whirl
# over the window in reasonable time, and the passage is quasi-static anyway (the steady response); the shipped
# extreme scene spinup_100x_slower spans 1.42e4 periods and solves (tests/test_extreme.py)
CRITICAL_RATIO = 2.0
MAX_PERIODS = 2e4


@dataclass(frozen=True)
class PathConstraint:
    """lb <= expr(q, a*, v) <= ub at every path point; ``name`` names it in messages."""

    name: str
    expr: ca.Function  # (q, a_star, v) -> scalar, already scaled to O(1)
    lb: float
    ub: float
    uses_control: bool = False  # then also imposed at each interval start, where the control jumps


class Dimensionless:
    """The dimensionless data of a spin-up problem from its SI members (omega_start, omega_final, horizon,
    settling_time, alpha_max, alpha_min, omega_max in rad/s, s, rad/s^2) and its time scale ``Om`` (1/s): time
    tau = Om t, speed nu = omega/Om, acceleration a* = alpha/Om^2; the objective ``min_time`` frees the final time.  The
    Jeffcott rotor's problem scales by its Omega0, the modal rotor's by omega_final."""

    @property
    def free_time(self) -> bool:
        return self.objective == "min_time"

    @property
    def nu0(self) -> float:
        return self.omega_start / self.Om

    @property
    def nuf(self) -> float:
        return self.omega_final / self.Om

    @property
    def tau_h(self) -> float:
        return self.horizon * self.Om

    @property
    def tau_s(self) -> float:
        return self.settling_time * self.Om

    @property
    def a_max(self) -> float:
        return self.alpha_max / self.Om**2

    @property
    def u_min(self) -> float:
        """Lower bound of the control u = alpha/alpha_max: -1, or the minimum acceleration's (``alpha_min``, rad/s^2,
        <= 0; 0: the speed never falls) if higher."""
        return -1.0 if self.alpha_min is None else max(-1.0, self.alpha_min / self.alpha_max)

    @property
    def torque_bounds(self) -> tuple[float, float]:
        """(lowest, highest) drive torque allowed, N m (+-inf where no limit): -braking limit (or -max_torque),
        max_torque."""
        hi = np.inf if self.torque_max is None else self.torque_max
        lo = -hi if self.braking_torque_max is None else -self.braking_torque_max
        return lo, hi

    def drive_constraints(self, M, nu, add) -> None:
        """The drive's path constraints, each by ``add(name, expr, lb, ub)``: the torque (or braking) limits, the
        power limit and the motor characteristic on the drive torque ``M`` (N m) and the speed ``nu`` (omega/Om),
        CasADi expressions of the state and the control; each row scaled to order one."""
        lo, hi = self.torque_bounds
        if self.torque_max is not None:
            name = f"torque limit |M| <= {self.torque_max:g} N m" if lo == -hi else \
                f"torque limits -{-lo:g} <= M <= {hi:g} N m"
            add(name, M / hi, lo / hi, 1.0)
        elif self.braking_torque_max is not None:  # scaled by the inertial torque of the full acceleration
            ref = self.braking_torque_max or self.inertia * self.alpha_max
            add(f"braking limit M >= -{-lo:g} N m", M / ref, lo / ref, ca.inf)
        if self.power_max is not None:
            add(f"power limit M omega <= {self.power_max:g} W", M * nu * self.Om / self.power_max, -ca.inf, 1.0)
        if self.motor_stall_torque is not None:
            L = self.motor_stall_torque * (1 - nu * self.Om / self.motor_no_load_speed)
            add("motor characteristic M <= L_s (1 - omega/omega_nl)", (M - L) / self.motor_stall_torque, -ca.inf,
                0.0)

    def check_drive(self) -> None:
        """Refuse torque and power limits without the inertia the drive accelerates, a negative braking limit and a
        positive minimum acceleration (the speed is held over the settling window)."""
        if (self.torque_max or self.power_max or self.motor_stall_torque or self.braking_torque_max is not None) \
                and self.inertia <= 0:
            raise ValueError("torque and power limits need the drive's polar inertia J_p > 0")
        if self.braking_torque_max is not None and self.braking_torque_max < 0:
            raise ValueError("the braking-torque limit must not be negative (N m; 0: no braking)")
        if self.alpha_min is not None and self.alpha_min > 0:
            raise ValueError("the minimum acceleration must not be positive (rad/s^2): the speed is held at the end")

    def nu_bounds(self) -> tuple[float, float]:
        """Bounds of nu on the horizon: 0, and the speed cap when there is one."""
        return 0.0, (self.omega_max / self.Om if self.omega_max is not None else ca.inf)


@dataclass
class SpinupOcp(Dimensionless):
    """Declaration of the spin-up problem in SI (converted to the dimensionless form inside)."""

    params: RotorParams
    omega_start: float  # rad/s
    omega_final: float  # rad/s
    horizon: float  # s (the upper bound of the final time when it is free)
    alpha_max: float  # rad/s^2
    objective: str = "peak_deflection"
    settling_time: float = 0.0  # s, window held at omega_final after the horizon
    omega_max: float | None = None  # rad/s
    torque_max: float | None = None  # N m
    braking_torque_max: float | None = None  # N m, -M <= this (0: no braking; None: up to torque_max)
    alpha_min: float | None = None  # rad/s^2, <= 0: alpha >= this (0: the speed never falls; None: -alpha_max)
    power_max: float | None = None  # W
    motor_stall_torque: float | None = None  # N m, L_s
    motor_no_load_speed: float | None = None  # rad/s, omega_nl
    deflection_limit: float | None = None  # delta/e (min_time, or an extra limit for any objective)
    jerk_max: float | None = None  # rad/s^3, bound on the change of alpha between control intervals
    jerk_penalty: float = 0.0  # weight of sum (Delta u)^2, u = alpha/alpha_max, relative to the objective
    # weight of the total variation of u = alpha/alpha_max (sum |Delta u|, smoothed below |Delta u| = 0.01),
    # relative to the objective: removes one-interval pulses without rounding the switches (the default)
    jerk_variation: float = JERK_VARIATION

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}")
        if self.objective == "min_time" and self.deflection_limit is None:
            raise ValueError("the min_time objective needs a deflection_limit")
        self.check_drive()
        if self.jerk_penalty < 0 or self.jerk_variation < 0:
            raise ValueError("jerk_penalty and jerk_variation must not be negative")
        if self.jerk_max is not None and self.jerk_max <= 0:
            raise ValueError("jerk_max must be positive (rad/s^3)")

    def ill_posed(self) -> str | None:
        """Why the problem cannot be posed as a spin-up through the critical speed (one line), or None."""
        P = self.params
        wc = P.omega_cr
        top = max(self.omega_start, self.omega_final, self.omega_max or 0.0)
        if wc > CRITICAL_RATIO * top:
            d = top**2 / abs(wc**2 - top**2)
            return (f"the critical speed {wc:.4g} rad/s ({wc * 30 / np.pi:.4g} rpm) is {wc / top:.3g} times the "
                    f"highest speed {top:.4g} rad/s: the spin-up never nears it, its peak is about the steady "
                    f"deflection at the top speed (delta/e = {d:.3g}), which no profile changes (check the rotor's "
                    "stiffness or critical speed)")
        periods = (self.horizon + self.settling_time) * wc / (2 * np.pi)
        if periods > MAX_PERIODS:
            return (f"horizon + settling_time = {self.horizon + self.settling_time:.4g} s span {periods:.3g} natural "
                    f"periods of the rotor (2 pi/omega_cr = {2 * np.pi / wc:.3g} s), more than {MAX_PERIODS:.0e}: "
                    "shorten them (the passage is quasi-static long before)")
        return None

    # dimensionless data (Pashkov 2010, Eq. (2)): the time scale Omega0
    @property
    def Om(self) -> float:
        return self.params.Omega0

    @property
    def inertia(self) -> float:
        """What the drive accelerates, kg m^2: J_p of rotor and drive, and the unbalance mass off the axis."""
        P = self.params
        return P.J_p + P.m1 * P.e**2 * (1 - P.psi)

    @property
    def drag(self) -> float:
        """The drive's rotational drag b, N m s."""
        return self.params.b

    @property
    def q0(self) -> list[float]:
        return steady_q(self.params, self.nu0) if self.nu0 > 0 else [0.0] * self.nx

    @property
    def n_extra(self) -> int:
        """Extra decision variables v: the epigraph level (peak objectives) or the final time."""
        return 1 if self.objective != "integrated_deflection" else 0

    # the model as the transcription, the simulation and the solver see it (:mod:`autobal.ocp.transcription`):
    # its state, its equation, the measure the epigraph bounds; the modal rotor's problem has the same members
    @property
    def nx(self) -> int:
        """Number of states of the model (:data:`autobal.models.rotor.STATES`)."""
        return len(STATES)

    @property
    def speed_index(self) -> int:
        """Where the speed nu = omega/Omega0 sits in the state."""
        return STATES.index("nu")

    @property
    def p(self) -> list[float]:
        """The parameters of :meth:`rhs`."""
        return self.params.p

    def rhs(self) -> ca.Function:
        """(q, a*, p) -> dq/dtau: the rotating-frame model (:func:`autobal.models.rotor.rotor_model`)."""
        return rotor_model().ode

    def deflection2(self) -> ca.Function:
        """q -> (delta/e)^2: the integrand of the integrated objective."""
        return rotor_model().delta2

    def epigraph2(self, states: np.ndarray) -> np.ndarray:
        """The squared measure the epigraph bounds ((delta/e)^2, or d^2 for peak_unbalance) at states (..., nx)."""
        if self.objective == "peak_unbalance":
            return unbalance(np.reshape(states, (-1, self.nx)).T, self.params.psi) ** 2
        return states[..., 0] ** 2 + states[..., 1] ** 2

    def deflection_of(self, states: np.ndarray) -> dict:
        """The deflection at states (k, nx) for a failed solve's last iterate, named with its unit."""
        return {"deflection_over_e": list(np.hypot(states[:, 0], states[:, 1]))}

    deflection_unit = "1"  # of deflection_limit and of the peaks: delta/e (the modal rotor's problem: m)
    epigraph_unit = 1.0  # the reported peak is sqrt(epigraph level) times this (delta/e and d are reported as they are)
    max_steps = 20000  # CVODES steps per integrator call at most
    # the coarse solves of the starts begin with the collocation states held at the interval-start values (rockit's
    # guess): from a coarse mesh the Jeffcott rotor reaches better basins so (benchmarks/spinup_ocp.md)
    hold_states = True

    # the solver's parts of this model (:class:`autobal.ocp.protocol.SpinupProblem`): the functions of
    # :mod:`autobal.ocp.solve` and :mod:`autobal.ocp.simulation` (imported in each method: those modules sit below
    # this one, importing it for type checking only)
    def starts(self, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
        """Labelled initial control profiles on n control intervals (:func:`autobal.ocp.solve.starts`)."""
        from autobal.ocp.solve import starts
        return starts(self, n, multistart)

    def reference_level(self) -> float:
        """The scale of the objective (:func:`autobal.ocp.solve.reference_level`)."""
        from autobal.ocp.solve import reference_level
        return reference_level(self)

    def resimulate(self, u, h, label: str):
        """CVODES re-simulation of the control u on intervals h, tau (:func:`autobal.ocp.simulation.resimulate`)."""
        from autobal.ocp.simulation import resimulate
        return resimulate(self, u, h, label)

    def rank_coarse(self, found: list, n: int) -> tuple[int, dict[int, float]]:
        """The best of the coarse optima ``found`` (:func:`autobal.ocp.solve.rank_coarse`)."""
        from autobal.ocp.solve import rank_coarse
        return rank_coarse(self, found, n)

    def perturbed(self, factors) -> SpinupOcp:
        """The problem of the rotor with the factors (critical speed, damping, liquid mass) applied
        (:meth:`autobal.models.rotor.RotorParams.scaled`); the drive, speeds, deadline and limits the same (a
        scenario of the robust study, :mod:`autobal.ocp.robust`)."""
        return dataclasses.replace(self, params=self.params.scaled(*factors))

    def dynamics(self) -> ca.Function:
        """(q, u, h) -> h f(q, u a*_max): the model over an interval of length h."""
        q, u, h = ca.SX.sym("q", self.nx), ca.SX.sym("u"), ca.SX.sym("h")
        return ca.Function("spinup_f", [q, u, h], [h * self.rhs()(q, u * self.a_max, self.p)])

    def path_constraints(self, ref: float) -> list[PathConstraint]:
        """Named path constraints; ``ref`` is the scale of the epigraph level (delta^2 or d^2)."""
        m, P = rotor_model(), self.params
        q, a, v = ca.SX.sym("q", self.nx), ca.SX.sym("a"), ca.SX.sym("v", self.n_extra)
        out = []

        def add(name, expr, lb, ub):
            out.append(PathConstraint(name, ca.Function(f"path{len(out)}", [q, a, v], [expr]), lb, ub,
                                      ca.depends_on(expr, a)))

        if self.objective == "peak_deflection":
            add("deflection epigraph delta^2 <= S", (m.delta2(q) - v[0] * ref) / ref, -ca.inf, 0.0)
        elif self.objective == "peak_unbalance":
            add("unbalance epigraph d^2 <= S", (m.unbalance2(q, P.p) - v[0] * ref) / ref, -ca.inf, 0.0)
        if self.deflection_limit is not None:
            add(f"deflection limit delta/e <= {self.deflection_limit:g}", m.delta2(q) / self.deflection_limit**2,
                -ca.inf, 1.0)
        self.drive_constraints(m.torque(q, a, P.p) * P.torque_scale, q[self.speed_index], add)
        return out


def pulse_variation(u) -> float:
    """Chattering measure of a piecewise-constant control: the total variation that a three-point running
    median removes, TV(u) - TV(median3(u)), with TV(u) = sum |u_(k+1) - u_k|.

    A one-interval pulse of height a above (or below) both neighbours adds 2a; the intermediate value of
    a switch that falls inside an interval (between its neighbours: the discretisation of a switching
    instant on a fixed mesh), a bang arc and a smooth arc add nothing (the median keeps monotone runs).

    Parameters
    ----------
    u : array_like
        The control on consecutive intervals, here alpha/alpha_max (dimensionless).

    Returns
    -------
    float
        The pulses' share of the total variation, in the units of u (0 for a profile without pulses).
    """
    u = np.asarray(u, dtype=float)
    if u.size < 3:
        return 0.0
    med = u.copy()
    med[1:-1] = np.median(np.stack([u[:-2], u[1:-1], u[2:]]), axis=0)
    return float(np.abs(np.diff(u)).sum() - np.abs(np.diff(med)).sum())
