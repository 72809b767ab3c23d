"""Minimum-peak spin-up of a multi-mode rotor (a ROSS rotor reduced to its modes,
:mod:`autobal.models.ross_rotor`) through two or more critical speeds.

The drive is posed as in the Jeffcott scenes: |alpha| <= alpha_max, omega_final reached by the deadline
(``horizon``), held over ``settling_time`` (the peak counts over the whole window), omega <= omega_max.
The objective is the peak over time of the largest lateral deflection sqrt(x^2 + y^2) at the nodes of
interest.

Transcription: Radau collocation (:func:`autobal.ocp.transcription.collocation_data`) of the complex
envelope S of the modal state (s = Re(S e^{i phi}), :mod:`autobal.models.ross_rotor`), which is smooth where
the rotor whirls at the running speed; control alpha/alpha_max piecewise constant per interval.  The
deflection envelope of a node with complex amplitudes (X, Y) is the major half-axis of its orbit,
r^2 = (|X|^2 + |Y|^2 + |X^2 + Y^2|)/2 (smoothed: |W| -> sqrt(|W|^2 + eps^2)); epigraph r^2 <= S ref at every
collocation point, minimise S.  The spin-up transcription of the Jeffcott rotor (ocp/transcription.py)
is written for its five states, so this module has its own small collocation; it reuses the
collocation coefficients and the IPOPT wrapper.

Every reported peak is the CVODES re-simulation of the physical (fixed-frame) response, max_t sqrt(x^2 + y^2).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from autobal.analysis import ipopt
from autobal.analysis.result import Result, new_figure
from autobal.errors import SolveError
from autobal.models.ross_rotor import ModalRotor
from autobal.ocp.transcription import collocation_data

RESIM_TOL = 1e-9  # CVODES relative tolerance of the re-simulation
POINTS_PER_REV = 64  # output points per revolution of the re-simulation (peak between them: < 1e-3)
EPS = 1e-3  # smoothing of |X^2 + Y^2| in the envelope, relative to the reference deflection


@dataclass
class ModalSpinupOcp:
    """The spin-up problem of a reduced rotor, in SI."""

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

    def __post_init__(self):
        if abs(self.omega_final - self.omega_start) > self.alpha_max * self.horizon:
            raise ValueError(f"|alpha| <= {self.alpha_max:g} rad/s^2 cannot reach {self.omega_final:g} rad/s "
                             f"from {self.omega_start:g} rad/s within the horizon {self.horizon:g} s")
        for nd in self.nodes:
            self.rotor.node_rows(nd)

    @property
    def h(self) -> float:
        """Control interval, s."""
        return self.horizon / self.intervals

    @property
    def settling_intervals(self) -> int:
        return int(np.ceil(self.settling_time / self.h - 1e-9)) if self.settling_time > 0 else 0

    @cached_property
    def amplitude_scale(self) -> float:
        """a: the largest steady modal amplitude |E(omega)| up to omega_final (scales the states)."""
        w = np.linspace(0, self.omega_final, 400)
        return float(max(np.abs(self.rotor.steady_amplitude(x)).max() for x in w)) or 1.0

    def envelope_rhs(self) -> ca.Function:
        """(x, u) -> dx/dt of the scaled envelope state x = (Re p, Im p, Re q, Im q, nu), p = P/a,
        q = Q/(a omega_f), nu = omega/omega_f, u = alpha/alpha_max."""
        R, n, a, wf = self.rotor, self.rotor.n, self.amplitude_scale, self.omega_final
        x, u = ca.SX.sym("x", 4 * n + 1), ca.SX.sym("u")
        pr, pi, qr, qi, nu = x[:n], x[n:2 * n], x[2 * n:3 * n], x[3 * n:4 * n], x[4 * n]
        w, al = nu * wf, u * self.alpha_max
        fr, fi = R.force_amplitude(w, al)
        ode = R.ode()
        ddr = ode(a * pr, a * wf * qr, w, al, fr) / (a * wf)
        ddi = ode(a * pi, a * wf * qi, w, al, fi) / (a * wf)
        dx = ca.vertcat(wf * qr + w * pi, wf * qi - w * pr, ddr + w * qi, ddi - w * qr, al / wf)
        return ca.Function("envelope", [x, u], [dx])

    def envelope2(self) -> ca.Function:
        """x -> the squared deflection envelope of each node of interest over a^2 (smoothed)."""
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

    @cached_property
    def peak_scale2(self) -> float:
        """(largest steady deflection of the nodes of interest / a)^2: the scale of the epigraph level."""
        w = np.linspace(0, self.omega_final, 400)
        a = self.amplitude_scale
        return max(float(np.max(np.abs(self.rotor.node_rows(nd) @ self.rotor.steady_amplitude(x)))) / a
                   for nd in self.nodes for x in w) ** 2

    def x0(self) -> np.ndarray:
        """The steady envelope at omega_start (scaled)."""
        E = self.rotor.steady_amplitude(self.omega_start) / self.amplitude_scale
        Q = 1j * self.omega_start * E / self.omega_final
        return np.concatenate([E.real, E.imag, Q.real, Q.imag, [self.omega_start / self.omega_final]])


def ramp_controls(ocp: ModalSpinupOcp, alpha: float, n: int | None = None) -> np.ndarray:
    """u = alpha/alpha_max on n control intervals: a constant ramp at ``alpha`` until omega_final, then hold."""
    n = n or ocp.intervals
    h = ocp.horizon / n
    w = np.minimum(ocp.omega_final, ocp.omega_start + alpha * h * np.arange(n + 1)) if ocp.omega_final > \
        ocp.omega_start else np.maximum(ocp.omega_final, ocp.omega_start - alpha * h * np.arange(n + 1))
    return np.clip(np.diff(w) / h / ocp.alpha_max, -1, 1)


def _interval_integrator(ocp: ModalSpinupOcp, fractions, tol: float) -> ca.Function:
    f = ocp.envelope_rhs()
    nx = f.size1_in(0)
    x, p = ca.SX.sym("x", nx), ca.SX.sym("p", 2)  # p = (u, h)
    return ca.integrator("envelope_interval", "cvodes", {"x": x, "p": p, "ode": p[1] * f(x, p[0])}, 0,
                         list(fractions), {"abstol": tol, "reltol": tol, "max_num_steps": 100000})


def simulate_envelope(ocp: ModalSpinupOcp, u: np.ndarray, fractions, tol: float = 1e-8) -> np.ndarray:
    """The envelope state at the ``fractions`` of every interval (settling window included), (K, len, nx)."""
    F = _interval_integrator(ocp, fractions, tol)
    x, out = ocp.x0(), []
    for uk in u:
        xf = np.array(F(x0=x, p=[uk, ocp.h])["xf"])
        out.append(xf.T)
        x = xf[:, -1]
    return np.array(out)


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


def fixed_frame_integrator(rotor: ModalRotor, points: int, tol: float = RESIM_TOL, scale: float = 1.0
                           ) -> ca.Function:
    """CVODES of the physical modal state (eta/scale, eta'/scale, omega, phi) over one interval of constant
    acceleration; parameters (alpha, h); outputs at ``points`` evenly spaced instants after its start."""
    n = rotor.n
    x, p = ca.SX.sym("x", 2 * n + 2), ca.SX.sym("p", 2)
    eta, deta, w, ph = x[:n], x[n:2 * n], x[2 * n], x[2 * n + 1]
    fr, fi = rotor.force_amplitude(w, p[0])
    f = ca.cos(ph) * fr - ca.sin(ph) * fi  # Re(F^ e^{i phi})
    dd = rotor.ode()(eta, deta, w, p[0], f / scale)
    return ca.integrator("modal_fixed", "cvodes", {"x": x, "p": p, "ode": p[1] * ca.vertcat(deta, dd, p[0], w)},
                         0, list(np.linspace(0, 1, points + 1)[1:]),
                         {"abstol": tol, "reltol": tol, "max_num_steps": 500000})


def simulate_fixed(rotor: ModalRotor, omega_start: float, alpha: np.ndarray, h: np.ndarray, nodes,
                   from_rest: bool = False, tol: float = RESIM_TOL):
    """The physical response to a piecewise-constant acceleration (alpha (rad/s^2) on intervals h (s)),
    from the steady state at omega_start (or from rest, as ROSS's time response starts), sampled at
    least POINTS_PER_REV times per revolution.

    Parameters
    ----------
    rotor : ModalRotor
    omega_start : float
        rad/s.
    alpha, h : ndarray
        Acceleration (rad/s^2) and length (s) of each interval.
    nodes : sequence of int
    from_rest : bool
        Start from rest instead of the steady state.
    tol : float
        CVODES tolerance (relative; absolute on the scaled states).

    Returns
    -------
    t (s), omega (rad/s), xy (len(nodes), 2, len(t)) deflections in m
    """
    n = rotor.n
    a = float(np.abs(rotor.unbalance).max()) or 1.0
    E = np.zeros(n, complex) if from_rest else rotor.steady_amplitude(omega_start)
    x = np.concatenate([E.real / a, (1j * omega_start * E).real / a, [omega_start, 0.0]])
    w_top = np.max(np.abs(omega_start + np.concatenate([[0], np.cumsum(np.asarray(alpha) * h)])))
    m = max(4, int(np.ceil(w_top * np.max(h) / (2 * np.pi) * POINTS_PER_REV)))
    F = fixed_frame_integrator(rotor, m, tol, a)
    frac = np.linspace(0, 1, m + 1)[1:]
    ts, ws, ys, t0 = [np.zeros(1)], [np.array([omega_start])], [x[:n][:, None]], 0.0
    for al, hk in zip(alpha, h, strict=True):
        xf = np.array(F(x0=x, p=[al, hk])["xf"])
        ts.append(t0 + hk * frac)
        ws.append(xf[2 * n])
        ys.append(xf[:n])
        x, t0 = xf[:, -1], t0 + hk
    eta = np.hstack(ys) * a
    xy = np.array([rotor.node_rows(nd) @ eta for nd in nodes])
    return np.concatenate(ts), np.concatenate(ws), xy


def resimulate(ocp: ModalSpinupOcp, u: np.ndarray, label: str) -> ModalTrajectory:
    """CVODES re-simulation (fixed frame) of the control u (over alpha_max) on the OCP's intervals, settling
    window included."""
    K = len(u)
    h = np.full(K, ocp.h)
    t, w, xy = simulate_fixed(ocp.rotor, ocp.omega_start, u * ocp.alpha_max, h, ocp.nodes)
    return ModalTrajectory(label, t, w, np.hypot(xy[:, 0], xy[:, 1]), tuple(ocp.nodes), np.arange(K) * ocp.h,
                           u * ocp.alpha_max)


@dataclass
class ModalSolution:
    u: np.ndarray  # over alpha_max, all intervals (settling window zeros)
    status: str
    iterations: int
    solve_time_s: float
    collocation_peak: float  # m, largest envelope at the collocation points
    start: str


class ModalSolver:
    """The collocation NLP of a ModalSpinupOcp, built once, solved from any control profile."""

    def __init__(self, ocp: ModalSpinupOcp, options: dict | None = None):
        t0 = time.perf_counter()
        self.ocp = ocp
        d = ocp.degree
        tau, C, D, _ = collocation_data(d, "radau")
        self.fractions = tau
        f, env = ocp.envelope_rhs(), ocp.envelope2()
        nx, N, Ns = f.size1_in(0), ocp.intervals, ocp.settling_intervals
        K = N + Ns
        self.K = K
        self.ref = ocp.peak_scale2
        per = nx * (d + 1) + 1
        w = ca.MX.sym("w", K * per + nx + 1)
        Wk = ca.reshape(w[:K * per], per, K)  # column k: X_k, Xc_k (d nx), u_k
        X = ca.horzcat(Wk[:nx, :], w[K * per:K * per + nx])  # (nx, K + 1)
        S = w[-1]
        self.idx_X = np.array([np.arange(nx) + k * per for k in range(K)] + [np.arange(nx) + K * per])
        self.idx_Xc = np.array([[np.arange(nx) + k * per + nx * (j + 1) for j in range(d)] for k in range(K)])
        self.idx_u = np.array([k * per + per - 1 for k in range(K)])
        lbx, ubx = np.full(w.numel(), -np.inf), np.full(w.numel(), np.inf)
        lbx[self.idx_X[0]] = ubx[self.idx_X[0]] = ocp.x0()
        lbx[self.idx_u[:N]], ubx[self.idx_u[:N]] = -1.0, 1.0
        lbx[self.idx_u[N:]] = ubx[self.idx_u[N:]] = 0.0
        nu_max = (ocp.omega_max / ocp.omega_final) if ocp.omega_max is not None else np.inf
        for rows in (self.idx_X[1:N, -1], self.idx_Xc[:N, :, -1].ravel()):
            lbx[rows], ubx[rows] = 0.0, nu_max
        lbx[-1] = 0.0
        # one interval as a Function (collocation equations, continuity, epigraph), mapped over the mesh
        xk, xn, uk, s = ca.SX.sym("xk", nx), ca.SX.sym("xn", nx), ca.SX.sym("u"), ca.SX.sym("S")
        zc = [ca.SX.sym(f"z{j}", nx) for j in range(d)]
        Z = [xk, *zc]
        eqs = [sum(C[r, j] * Z[r] for r in range(d + 1)) - ocp.h * f(zc[j], uk) for j in range(d)]
        eqs.append(xn - sum(D[r] * Z[r] for r in range(d + 1)))
        epi = ca.vertcat(*[env(zc[j]) / self.ref - s for j in range(d)])
        interval = ca.Function("interval", [xk, ca.vertcat(*zc), uk, xn, s], [ca.vertcat(*eqs), epi])
        dyn, ep = interval.map(K)(X[:, :K], Wk[nx:nx * (d + 1), :], Wk[per - 1, :], X[:, 1:], S)
        g = [ca.vec(dyn), X[-1, N] - 1.0, ca.vec(ep)]  # omega(T) = omega_final
        ndyn, nep = dyn.numel(), ep.numel()
        lbg = [np.zeros(ndyn), [0.0], np.full(nep, -np.inf)]
        ubg = [np.zeros(ndyn), [0.0], np.zeros(nep)]
        self.nlp = {"x": w, "f": S, "g": ca.vertcat(*g)}
        self.lbx, self.ubx = lbx, ubx
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        opts = {"tol": 1e-8, "constr_viol_tol": 1e-8, "max_iter": 1000, "mu_strategy": "adaptive"} | (options or {})
        self.solver = ipopt.nlpsol("modal_spinup", w, ca.MX.sym("p", 0), S, ca.vertcat(*g), **opts)
        self.env = env
        self.build_time_s = time.perf_counter() - t0

    def guess(self, u: np.ndarray) -> np.ndarray:
        """All NLP variables from a control profile u (n control intervals): the envelope simulated."""
        ocp = self.ocp
        uu = np.concatenate([u, np.zeros(self.K - len(u))])
        sim = simulate_envelope(ocp, uu, self.fractions)
        w0 = np.zeros(self.nlp["x"].numel())
        w0[self.idx_Xc] = sim
        w0[self.idx_X[1:]] = sim[:, -1, :]
        w0[self.idx_X[0]] = ocp.x0()
        w0[self.idx_u] = uu
        lev = np.array(self.env.map(sim.shape[0] * sim.shape[1])(sim.reshape(-1, sim.shape[2]).T))
        w0[-1] = 1.05 * lev.max() / self.ref
        return w0

    def solve(self, u: np.ndarray, label: str) -> ModalSolution:
        """IPOPT from the control profile u; SolveError with the status when it fails."""
        w0 = self.guess(u)
        t0 = time.perf_counter()
        r = ipopt.solve(self.solver, x0=w0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        dt = time.perf_counter() - t0
        if not r["success"]:
            raise SolveError(f"multi-mode spin-up OCP not solved from the {label}: IPOPT {r['status']} after "
                             f"{r['iterations']} iterations", r["status"], {"alpha_rad_s2": list(
                                 r["x"][self.idx_u] * self.ocp.alpha_max)})
        wopt = r["x"]
        peak = float(np.sqrt(wopt[-1] * self.ref)) * self.ocp.amplitude_scale
        return ModalSolution(wopt[self.idx_u], r["status"], r["iterations"], dt, peak, label)


def starts(ocp: ModalSpinupOcp) -> list[tuple[str, np.ndarray]]:
    """Initial profiles: the maximum-acceleration ramp and hold, the constant ramp to the deadline, and the
    ramp at the mean of both."""
    const = abs(ocp.omega_final - ocp.omega_start) / ocp.horizon
    return [("maximum-acceleration ramp", ramp_controls(ocp, ocp.alpha_max)),
            ("constant ramp", ramp_controls(ocp, const)),
            ("ramp at the mean of both", ramp_controls(ocp, 0.5 * (const + ocp.alpha_max)))]


def baselines(ocp: ModalSpinupOcp) -> dict[str, ModalTrajectory]:
    """The constant ramp to the deadline and the maximum-acceleration ramp with hold, re-simulated."""
    const = abs(ocp.omega_final - ocp.omega_start) / ocp.horizon
    zeros = np.zeros(ocp.settling_intervals)
    out = {}
    for key, a in (("constant_ramp", const), ("max_acceleration_ramp", ocp.alpha_max)):
        lab = f"constant ramp {a:.4g} rad/s^2" if key == "constant_ramp" else f"ramp {a:.4g} rad/s^2 and hold"
        out[key] = resimulate(ocp, np.concatenate([ramp_controls(ocp, a), zeros]), lab)
    return out


@dataclass
class ModalOptimum:
    solution: ModalSolution
    trajectory: ModalTrajectory
    starts: list
    build_time_s: float

    @property
    def resimulation_rel_error(self) -> float:
        """|collocation peak - re-simulated peak| / re-simulated peak."""
        return abs(self.solution.collocation_peak - self.trajectory.peak) / self.trajectory.peak


def optimize(ocp: ModalSpinupOcp, options: dict | None = None) -> ModalOptimum:
    """Solve from every start; keep the best optimum by its re-simulated peak."""
    solver = ModalSolver(ocp, options)
    rows, best, err = [], None, None
    for label, u in starts(ocp):
        try:
            sol = solver.solve(u, label)
        except SolveError as exc:
            rows.append({"start": label, "status": exc.status, "error": str(exc)})
            err = err or exc
            continue
        tr = resimulate(ocp, sol.u, "optimum")
        rows.append({"start": label, "status": sol.status, "iterations": sol.iterations,
                     "solve_time_s": sol.solve_time_s, "collocation_peak_m": sol.collocation_peak,
                     "resimulated_peak_m": tr.peak})
        if best is None or tr.peak < best[1].peak * (1 - 1e-4):
            best = (sol, tr)
    if best is None:
        raise err
    return ModalOptimum(best[0], best[1], rows, solver.build_time_s)
