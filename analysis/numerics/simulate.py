"""Time responses of the nonlinear device model (Pavlenko (2014), Eq. (2.111)) with CVODES/IDAS or RODAS4.

The model (models/dynamics.py) starts from its equilibrium, the IPOPT static solution, and is
driven by a step in axial force (dtau), a step in discharge pressure (dpsi1) or a harmonic
discharge pressure dpsi1a sin(omega t); with a pressure input the axial force follows it,
dtau = b dpsi1, unless the case says otherwise.  CasADi's CVODES (BDF, Newton with the exact
symbolic Jacobian) or IDAS integrates it on an output grid in one call, or RODAS4 (an L-stable
Rosenbrock method, analysis/numerics/rosenbrock.py) as one compiled loop of step attempts.

Reported, not hidden: the face gap reaching zero (u <= 0: the disc touches the pad; the model
has no contact force, so the response is cut there and the time is reported), the valve closing
(xi <= 0) or passing its travel limit, a reversal of the inner-seal flow (process fluid entering
the barrier chamber), and an integrator failure (the time reached and the solver's message).

Status: an integrator failure of any case, or a start that is not an equilibrium of the model (residual above
:data:`EQUILIBRIUM_TOL`), is a failure of the result (:meth:`TransientResult.failures`, first line of the summary;
the run's status "failed", CLI exit 3) with every case's response kept; a stop event (gap closed, runaway) ends a
case early by the model's own limits and is reported, not a failure.
The runner of ``analyses.transient`` is :func:`autobal.analyses.transient.run`.
"""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from autobal.analysis.numerics.compiled import compiled_map
from autobal.analysis.numerics.frequency import MODEL_LABELS
from autobal.analysis.numerics.rosenbrock import STATUS, rodas4_grid
from autobal.analysis.run import interrupt, solver_options
from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.result import failed_head, new_figure, unit_axis
from autobal.models.dynamics import DynamicModel

KINDS = ("force_step", "pressure_step", "pressure_harmonic")


ROSENBROCK = ("rodas4", "rodas4p")  # the compiled Rosenbrock integrators (analysis/numerics/rosenbrock.py)
U_RUNAWAY = 20.0  # gap over base gap beyond which a response is reported as a runaway and stopped


class Simulator:
    """A CasADi integrator of one model on one output grid, built once and called many times.

    Parameters of each call: the dynamic data (PARAM_NAMES order) and the input: step in psi1,
    step in tau, harmonic amplitude and frequency of psi1, the thrust coupling factor and a time
    offset.  The grid is integrated in chunks of ``chunk`` outputs so that a response stops where
    the gap closes or runs away (u > U_RUNAWAY) instead of integrating an unphysical state.  Each
    chunk restarts CVODES (order 1, a new initial step), which costs more than the outputs do: on the
    pump's 2001-point force step, chunks of 100 take 2.2x the time of chunks of 500.

    ``integrator="rodas4"``: RODAS4 (Hairer & Wanner (1996), Sect. IV.7), or ``"rodas4p"``: RODASP
    (Steinebach 1995; no order reduction where a stiff mode is driven by a harmonic input), with
    step-size control on the embedded error estimate, every step clipped to the next output time, as one
    CasADi Function of ``attempts`` step attempts (default 2 chunk + 254) compiled to C through
    :func:`autobal.analysis.numerics.compiled.compiled_map` (cached on disk; CasADi's virtual machine without a C
    compiler or with ``AUTOBAL_COMPILE=0``), called again until the chunk's last output is reached.  Its
    options: ``max_num_steps`` (step attempts allowed between two outputs, default the solver option
    ``transient.max_num_steps``, as CVODES'),
    ``attempts``, ``h0`` (first step, default 1e-4 of the output spacing, s) and ``linear_solver``
    (``"lu"``, default, or ``"qr"``).  A step size underflow or an exhausted step budget is a failure
    reported like a CVODES failure: the time reached and a message.
    """

    def __init__(self, model: DynamicModel, t_end: float, points: int, integrator: str = "cvodes",
                 rtol: float | None = None, atol: float | None = None, chunk: int = 500, **opts):
        """Build the integrator.

        Parameters
        ----------
        model : DynamicModel
            The device model (scaled states).
        t_end : float
            End time of the output grid, s.
        points : int
            Output times, uniform from 0 to ``t_end``.
        integrator : {"cvodes", "idas", "rodas4", "rodas4p"}
            CasADi's CVODES or IDAS, or the compiled RODAS4 / RODASP of analysis/numerics/rosenbrock.py.
        rtol, atol : float, optional
            Relative (-) and absolute tolerance (units of the scaled states, -); default the solver options
            ``transient.rtol`` and ``transient.atol`` (:mod:`autobal.analysis.run.solver_options`).
        chunk : int
            Outputs integrated in one call, between the checks of the stop events.
        **opts
            CasADi integrator options (CVODES, IDAS) or the RODAS4 options above.
        """
        self.model = model
        tol = solver_options.get("transient")
        self.rtol, self.atol = tol["rtol"] if rtol is None else rtol, tol["atol"] if atol is None else atol
        self.t = np.linspace(0.0, t_end, points)
        x = ca.SX.sym("x", len(model.states))
        t = ca.SX.sym("t")
        p = ca.SX.sym("p", len(model.p0))
        s = ca.SX.sym("s", 6)  # dpsi1 step, dtau step, harmonic amplitude, omega, coupling, time offset
        dpsi1 = s[0] + s[2] * ca.sin(s[3] * (t + s[5]))
        w = ca.vertcat(model.w0[0] + dpsi1, model.w0[1] + s[1] + s[4] * dpsi1)
        self._inputs = ca.Function("inputs", [t, s], [w])
        dae = {"x": x, "t": t, "p": ca.vertcat(p, s), "ode": model.ode(x, w, p)}
        o = {"reltol": self.rtol, "abstol": self.atol, "max_num_steps": tol["max_num_steps"],
             "disable_internal_warnings": True} | opts
        self.name = integrator
        self.compiled = False  # a compiled Rosenbrock loop (set by the RODAS4 build)
        self.chunk = max(1, min(chunk, points - 1))
        dt = self.t[1] - self.t[0]
        if integrator in ROSENBROCK:
            self._rodas4(x, t, p, s, w, dt, opts)
            return
        self._f = ca.integrator("sim", integrator, dae, 0.0, list(dt * np.arange(1, self.chunk + 1)), o)

    def _rodas4(self, x, t, p, s, w, dt: float, opts: dict) -> None:
        """Build the RODAS4 loop of step attempts (compiled when a C compiler is found)."""
        o = {"max_num_steps": solver_options.defaults["transient.max_num_steps"], "attempts": 2 * self.chunk + 254,
             "h0": 1e-4 * dt, "linear_solver": "lu"}
        unknown = set(opts) - set(o)
        if unknown:
            raise ValueError(f"unknown RODAS4 options {sorted(unknown)}; expected some of {sorted(o)}")
        o |= opts
        rhs = ca.Function("transient_rhs", [t, x, ca.vertcat(p, s)], [self.model.ode(x, w, p)])
        f = rodas4_grid(rhs, int(o["attempts"]), o["linear_solver"], self.name)
        self._f = compiled_map(f, 1) or f
        self.compiled = self._f is not f
        self.h0 = float(o["h0"])
        # the call through a buffer on numpy arrays (converting the attempts' DM output costs more than the loop)
        self._args = [np.zeros(8 + len(self.model.states)), np.array([dt]), np.zeros(1),
                      np.array([self.rtol, self.atol, float(o["max_num_steps"])]), np.zeros(p.numel() + s.numel())]
        self._W = np.zeros((int(o["attempts"]), 8 + len(self.model.states)))
        buf, self._eval = self._f.buffer()
        for i, a in enumerate(self._args):
            buf.set_arg(i, memoryview(a))
        buf.set_res(0, memoryview(self._W))
        self._buf = buf

    def _run_rodas4(self, x: np.ndarray, P: np.ndarray) -> dict:
        """The RODAS4 loop over the grid, chunk by chunk (see :meth:`run`)."""
        w, k_end, W = self._args[0], self._args[2], self._W
        self._args[4][:] = P
        self._args[4][-1] = 0.0  # RODAS4 integrates in absolute time
        n, iu = len(self.t) - 1, self.model.index("u")
        w[:] = np.concatenate([[0.0, self.h0, 0, 0, 0, 0, 0, 0], x])
        rows, stop, failure = [x], None, None
        while w[2] < n and stop is None and failure is None:
            k_end[0], got = min(int(w[2]) + self.chunk, n), []
            while w[2] < k_end[0] and w[7] == 0:
                interrupt.call(self._eval)
                got.append(W[W[:, 3] == 1, 8:])
                w[:] = W[-1]
            X = np.concatenate(got)
            rows.extend(X)
            if w[7] != 0:
                failure = {"t": float(w[0]),
                           "message": f"{self.name.upper()}: {STATUS[int(w[7])]} at t = {w[0]:.6g} s (step size "
                                      f"{w[1]:.3g} s, {int(w[6])} attempts since the output at t = "
                                      f"{self.t[int(w[2])]:.6g} s)"}
            if len(X) and (X[:, iu] <= 0).any():
                stop = "gap_closed"
            elif len(X) and ((X[:, iu] > U_RUNAWAY).any() or not np.isfinite(X).all()):
                stop = "gap_runaway"
        return {"t": self.t[: len(rows)], "X": np.array(rows), "stopped": stop, "failure": failure,
                "steps": int(w[4]), "rejected": int(w[5])}

    def input_vector(self, kind: str, amplitude: float, omega: float = math.nan, couple: bool = True) -> list:
        b = self.model.design.groups.b if couple else 0.0
        if kind == "force_step":
            return [0.0, amplitude, 0.0, 0.0, 0.0, 0.0]
        if kind == "pressure_step":
            return [amplitude, 0.0, 0.0, 0.0, b, 0.0]
        if kind == "pressure_harmonic":
            return [0.0, 0.0, amplitude, omega, b, 0.0]
        raise ValueError(f"unknown input {kind!r}; expected one of {KINDS}")

    def run(self, s: list, x_start: np.ndarray | None = None, p: np.ndarray | None = None) -> dict:
        """Integrate from ``x_start`` (default: the equilibrium); returns t, X (rows: time), the
        reason it stopped early (None, "gap_closed", "gap_runaway") and any integrator failure."""
        m = self.model
        x = m.x0 if x_start is None else np.asarray(x_start, float)
        P = np.concatenate([m.p0 if p is None else p, s])
        if self.name in ROSENBROCK:
            return self._run_rodas4(x, P)
        rows, k, stop, failure, steps = [x], 0, None, None, 0
        iu = m.index("u")
        n = len(self.t) - 1
        while k < n and stop is None:
            P[-1] = self.t[k]
            try:
                X = np.array(interrupt.call(self._f, x0=rows[-1], p=P)["xf"]).T
            except RuntimeError as exc:
                failure = {"t": float(self.t[k]), "message": str(exc).splitlines()[-1][:200]}
                break
            steps += int(self._f.stats().get("nsteps", 0))
            X = X[: n - k]
            rows.extend(X)
            k += len(X)
            if (X[:, iu] <= 0).any():
                stop = "gap_closed"
            elif (X[:, iu] > U_RUNAWAY).any() or not np.isfinite(X).all():
                stop = "gap_runaway"
        return {"t": self.t[: len(rows)], "X": np.array(rows), "stopped": stop, "failure": failure,
                "steps": steps}

    def inputs(self, s: list, t: np.ndarray) -> np.ndarray:
        """psi1(t), tau(t) of the input parameters ``s`` (rows: time)."""
        return np.array(self._inputs.map(len(t))(t, s)).T


def _time(description: str, symbol: str = "t"):
    return quantity("s", symbol, description, "ms")


@record
class Event(Record):
    """What happened along a response (:func:`events`): gap closed, valve at a stop, flow reversed, runaway."""

    event: str
    t: float = _time("time of an event (gap closed, valve at a stop, flow reversed)")
    message: str | None = optional()


@record
class IntegratorFailure(Record):
    """Where and why the integrator stopped before the end time."""

    t: float = _time("time the integrator failed")
    message: str


def _pressure():
    return quantity("Pa", "p2, p3", "chamber pressures over time")


@record
class Case(Record):
    """The time response of one case from the equilibrium; a failed case has no max |Δz|, final Δz (null with
    their status)."""

    input: str
    amplitude: float = quantity("1", "δψ1, δτ", "input amplitude, ratio of the discharge pressure or the load")
    frequency: float | None = quantity("rad/s", "ω", "frequency of a harmonic input", "rad/s")
    z: np.ndarray = quantity("m", "z", "face gap over time", "µm")
    p2: np.ndarray = _pressure()
    p3: np.ndarray = _pressure()
    max_dz: float | None = quantity("m", "max |Δz|", "largest face-gap change of a case", "µm", headline=1)
    final_dz: float | None = quantity("m", "Δz(t_end)", "face-gap change at the end of a case", "µm", headline=2)
    max_dz_status: str | None = optional(kw_only=True)
    final_dz_status: str | None = optional(kw_only=True)
    events: list[Event]
    failure: IntegratorFailure | None
    cpu_s: float = quantity("s", "", "CPU time of the integration")
    t_end: float = _time("time reached", "t_end")
    failure_status: str | None = optional(kw_only=True)
    frequency_status: str | None = optional(kw_only=True)
    integrator_steps: int = quantity("1", "", "integrator steps")
    #: the output times (s) and the states (rows: time; the source's groups) of the response: in its CSV
    t: np.ndarray | None = unsaved()
    X: np.ndarray | None = unsaved()


@record
class TransientResult(TypedResult):
    """Time responses of the nonlinear model from its equilibrium (Pavlenko (2014), Eq. (2.111)), a
    :class:`Case` each; the times and states of each response are held (its CSV), not in results.json."""

    title: str
    model: str
    integrator: str
    states: list[str]
    equilibrium_residual: float = quantity("1", "", "residual of the nonlinear model at the static solution",
                                           headline=3)
    #: the error estimate of :func:`accuracy` (its numbers are declared for every analysis: accuracy.**)
    accuracy: dict | None = optional(kw_only=True)
    cases: list[Case]
    failures_after = "equilibrium_residual"  # where results.json had them before the Result was typed
    name = "transient"

    @property
    def max_gap_change(self) -> list[float | None]:
        """Largest face-gap change max |z - z0| of each case, m (None: the case failed)."""
        return [c.max_dz for c in self.cases]

    def summary(self) -> str:
        lines = [*failed_head(self.failures()), f"transients ({self.model} model, {self.integrator}):"]
        dz = QUANTITIES.find("cases.0.max_dz")
        for c in self.cases:
            ev = "; ".join(e.message or f"{e.event} at t = {e.t:.4g} s" for e in c.events) or "none"
            fail = f"; integrator failed at t = {c.failure.t:.4g} s" if c.failure else ""
            response = "no response" if c.max_dz is None else \
                f"max |dz| = {dz.text(c.max_dz, 3)}, final dz = {dz.text(c.final_dz, 3)}"
            lines.append(f"  {c.input:17s} amplitude {c.amplitude:g}: {response}; events: {ev}{fail}")
        return "\n".join(lines)

    def _responses(self) -> list[Case]:
        """The cases with their responses; ValueError for a Result loaded from results.json, which holds the face
        gap and the pressures but not the times and states."""
        if any(c.t is None for c in self.cases):
            raise ValueError("transient: a loaded Result holds no time series (results.json has the face gap and "
                             "pressures; the times and states are in transient_<i>_<input>.csv of the run)")
        return self.cases

    def tables(self) -> dict[str, dict]:
        out = {}
        for i, c in enumerate(self._responses()):
            q_t, q_z, q_p = (QUANTITIES.find(f"cases.0.{k}") for k in ("t_end", "z", "p2"))
            cols = {f"t [{q_t.display}]": q_t.shown(np.asarray(c.t))}
            cols |= {f"{k} [1]": c.X[:, j] for j, k in enumerate(self.states)}  # the source's groups
            out[f"transient_{i}_{c.input}.csv"] = cols | {f"z [{q_z.display}]": q_z.shown(np.asarray(c.z)),
                                                          f"p2 [{q_p.display}]": q_p.shown(np.asarray(c.p2)),
                                                          f"p3 [{q_p.display}]": q_p.shown(np.asarray(c.p3))}
        return out

    def draw(self, ax) -> None:
        """The face-gap change of every case against time (the display units of the events' time, ms, and of the
        gap, µm)."""
        ft, fz = self._time_axis(ax), self._gap_axis(ax, r"$\delta z$")
        for c in self._responses():
            ax.plot(c.t * ft, (c.z - c.z[0]) * fz, label=f"{c.input} ({c.amplitude:g})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def _time_axis(self, ax) -> float:
        return unit_axis(ax, "t", "s", QUANTITIES.find("cases.0.t_end").declared, "x")

    def _gap_axis(self, ax, label: str) -> float:
        return unit_axis(ax, label, "m", QUANTITIES.find("cases.0.z").declared)

    def figures(self) -> dict[str, Figure]:
        n = len(self._responses())
        fig, axes = new_figure(figsize=(9, 2.6 * n + 0.4), nrows=n, ncols=2, squeeze=False)
        qz, qp = QUANTITIES.find("cases.0.z"), QUANTITIES.find("cases.0.p2")
        ft = [self._time_axis(a) for a in axes[-1]][0]  # the time below the last row
        for ax, c in zip(axes, self._responses(), strict=True):
            t = c.t * ft
            ax[0].plot(t, (c.z - c.z[0]) * self._gap_axis(ax[0], r"gap change $\delta z$"))
            ax[0].set_title(f"{c.input.replace('_', ' ')} ({c.amplitude:g}): face gap, "
                            rf"$z_0$ = {qz.text(c.z[0])}", fontsize=8)
            dp2, dp3 = c.p2 - c.p2[0], c.p3 - c.p3[0]
            big = max(np.abs(dp2).max(), np.abs(dp3).max())  # unless chosen: the unit of the changes' size
            fp = unit_axis(ax[1], r"pressure change $\Delta p$", "Pa",
                           "MPa" if big >= 1e6 else "kPa" if big >= 1e3 else "Pa")
            ax[1].plot(t, dp2 * fp, label=rf"$\Delta p_2$ (static {qp.text(c.p2[0], 3)})")
            ax[1].plot(t, dp3 * fp, label=rf"$\Delta p_3$ (static {qp.text(c.p3[0], 3)})")
            ax[1].set_title("chamber pressures relative to their static values", fontsize=8)
            ax[1].legend(fontsize=7, loc="best")
            for a in ax:
                a.grid(alpha=0.3)
                for e in c.events:
                    a.axvline(e.t * ft, color="r", ls=":", lw=0.8)
        fig.suptitle(f"{self.title}\ntime responses of the {MODEL_LABELS.get(self.model, '')} model "
                     "from the static solution (red dotted: events)", fontsize=9)
        return {"fig_transients.png": Figure(fig, "Nonlinear transients of the face gap and the chamber pressures")}


#: every number of the transient block (Pavlenko 2014, §2.5), from the fields: face-gap changes in m, shown in µm
TransientResult.quantities = QUANTITIES = declarations(TransientResult)


def events(model: DynamicModel, t: np.ndarray, X: np.ndarray, psi1: np.ndarray) -> list[Event]:
    """Gap closure, valve closure/limit and inner-seal flow reversal along a response."""
    out = []
    i_u = model.index("u")
    u = X[:, i_u]
    k = np.flatnonzero(u <= 0)
    if k.size:
        j = k[0]
        tc = t[j] if j == 0 else t[j - 1] + (t[j] - t[j - 1]) * u[j - 1] / (u[j - 1] - u[j])
        out.append(Event("gap_closed", float(tc), f"face gap reached zero at t = {tc:.6g} s: the disc touches "
                                                  "the pad (no contact model); response cut there"))
    if model.regulator:
        xi = X[:, model.index("xi")]
        xi_max = model.design.groups.regulator.xi_max
        for name, mask in (("valve_closed", xi <= 0), ("valve_at_travel_limit", xi >= xi_max)):
            if mask.any():
                out.append(Event(name, float(t[np.argmax(mask)])))
    q1 = X[:, model.index("psi2")] - psi1
    if (q1 < 0).any():
        out.append(Event("inner_seal_flow_reversed", float(t[np.argmax(q1 < 0)]),
                         "process fluid enters the barrier chamber (q1 < 0)"))
    if (u > U_RUNAWAY).any():
        out.append(Event("gap_runaway", float(t[np.argmax(u > U_RUNAWAY)]),
                         f"face gap grew past {U_RUNAWAY:g} z_B (unstable): response stopped"))
    return out


def study(model: DynamicModel, cases: list, duration: float, points: int, integrator: str = "cvodes",
          title: str = "") -> TransientResult:
    """Each case: dict with input, amplitude, frequency (harmonic; default omega0), couple."""
    sim = Simulator(model, duration, points, integrator)
    sc = model.design.scales
    out = []
    for case in cases:
        kind = case["input"]
        omega = case.get("frequency") or model.data.omega0
        s = sim.input_vector(kind, case["amplitude"], omega, case.get("couple", True))
        t0 = time.perf_counter()
        r = sim.run(s)
        cpu = time.perf_counter() - t0
        t, X = r["t"], r["X"]
        ev = events(model, t, X, sim.inputs(s, t)[:, 0])
        # the response ends where the gap closes or runs away (the rest of the chunk beyond is not the device's)
        cut = min((e.t for e in ev if e.event in ("gap_closed", "gap_runaway")), default=None)
        if cut is not None:
            keep = t <= cut
            t, X = t[keep], X[keep]
        z = X[:, model.index("u")] * sc["z_B"]
        dz = z - z[0]
        failure = None if r["failure"] is None else IntegratorFailure(**r["failure"])
        why = None if failure is None else \
            f"the integrator failed at t = {failure.t:.4g} s (the response up to there is in the CSV)"
        harmonic = kind == "pressure_harmonic"
        out.append(Case(
            input=kind, amplitude=case["amplitude"], frequency=omega if harmonic else None,
            t=t, X=X, z=z, p2=X[:, model.index("psi2")] * sc["p_B"], p3=X[:, model.index("psi3")] * sc["p_B"],
            # a failed case has no numbers: null with the reason, never those of the part it integrated
            max_dz=None if why else float(np.abs(dz).max()), final_dz=None if why else float(dz[-1]),
            max_dz_status=why, final_dz_status=why, events=ev, failure=failure, cpu_s=cpu, t_end=float(t[-1]),
            failure_status=None if failure else "none: the integrator reached the end time or a stop event",
            frequency_status=None if harmonic else "not a harmonic input", integrator_steps=r["steps"]))
    label = "nonlinear_chain" if model.form == "chain" else "nonlinear"
    eq = equilibrium_residual(model)
    failures = [f"case {i + 1} ({c.input}, amplitude {c.amplitude:g}): the integrator failed at "
                f"t = {c.failure.t:.4g} s: {c.failure.message}" for i, c in enumerate(out) if c.failure]
    if not eq <= EQUILIBRIUM_TOL:
        failures.append(f"the start is not an equilibrium of the model: residual {eq:.1e} > {EQUILIBRIUM_TOL:g}")
    return TransientResult(title=title, model=label, integrator=integrator, states=model.states,
                           equilibrium_residual=eq, cases=out, failures=failures)


# the largest implicit-row residual accepted at the start (rows normalised to O(1) coefficients): the static
# solution is accepted to 1e-6 of each balance's largest term (analysis/numerics/statics.py MAX_RELATIVE_RESIDUAL)
EQUILIBRIUM_TOL = 1e-6


def equilibrium_residual(model: DynamicModel) -> float:
    """Largest residual of the implicit rows at the static solution (each row normalised so that
    its own-pressure or stiffness coefficient is O(1)): zero when the equilibrium is the static solution."""
    n = len(model.coords)
    q0 = [float(model.point[k]) for k in model.coords]
    return float(np.abs(np.array(model.rows(q0, np.zeros(n), np.zeros(n), model.w0, model.p0))).max())


TIGHTER = 100.0  # the accuracy check reruns every case with rtol and atol divided by this


def accuracy(model: DynamicModel, res: TransientResult, cases: list, duration: float, points: int,
             integrator: str) -> dict:
    """Error estimate of the responses: every case rerun by the same integrator with tolerances
    ``TIGHTER`` times smaller; per case the largest difference of the face-gap response dz(t) over the
    common time grid relative to max |dz|, and the relative differences of max |dz| and the final dz."""
    sim = Simulator(model, duration, points, integrator)
    tight = Simulator(model, duration, points, integrator, rtol=sim.rtol / TIGHTER, atol=sim.atol / TIGHTER)
    iu, z_B = model.index("u"), model.design.scales["z_B"]
    per = []
    for case, c in zip(cases, res.cases, strict=True):
        if c.failure:  # no response to check
            why = c.max_dz_status
            per.append({"input": c.input} | {k: None for k in ("curve", "max_dz", "final_dz")}
                       | {f"{k}_status": why for k in ("curve", "max_dz", "final_dz")})
            continue
        omega = case.get("frequency") or model.data.omega0
        r = tight.run(tight.input_vector(case["input"], case["amplitude"], omega, case.get("couple", True)))
        k = min(len(c.z), len(r["t"]))
        dz, dz_t = c.z[:k] - c.z[0], (r["X"][:k, iu] - r["X"][0, iu]) * z_B
        ref = max(np.abs(dz_t).max(), 1e-300)
        per.append({"input": c.input, "curve": float(np.abs(dz - dz_t).max() / ref),
                    "max_dz": abs(c.max_dz - np.abs(dz_t).max()) / ref,
                    "final_dz": abs(c.final_dz - dz_t[-1]) / ref if k == len(c.z) else math.nan})
    failed = [p["input"] for p in per if p["curve"] is None]
    est = None if failed else \
        float(max(max(p["curve"], p["max_dz"], 0.0 if math.isnan(p["final_dz"]) else p["final_dz"]) for p in per))
    return {"estimate": est, "cases": per, "rtol": sim.rtol, "atol": sim.atol,
            "how": ("none: the integrator failed in a case, which has no response to check; " if failed else "")
            + f"largest difference of the face-gap response dz(t) (and of max |dz|, final dz) between the run "
                   f"at rtol {sim.rtol:g}, atol {sim.atol:g} and a rerun with {integrator} at {TIGHTER:g}x tighter "
                   "tolerances, relative to max |dz| of the case"}
