"""Amplitude- and phase-frequency characteristics of the face gap (Pavlenko 2014, (2.100)-(2.110)).

For a harmonic discharge pressure dpsi1 = dpsi1a sin(omega t) (with dtau = dpsi1, the appendix
convention, or dtau = b dpsi1) the gap amplitude in metres is
A_u(omega) = |W_u(i omega)| dpsi1a z_B (Pavlenko (2014), App. A and B, in micrometres there).  The Bode data
come from python-control (``control.frequency_response``) on a grid refined near every lightly damped
pole; peaks are local maxima refined with a bounded scalar search.  The runner of ``analyses.frequency`` is
:func:`autobal.analyses.frequency.run`.
"""

from __future__ import annotations

import dataclasses

import control
import numpy as np
from scipy.optimize import minimize_scalar

from autobal.analysis.numerics.linearize import LinearModel, Setup
from autobal.analysis.run import progress
from autobal.analysis.run.fields import Record, TypedResult, declarations, keyed, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import significant
from autobal.analysis.run.result import new_figure, unit_axis

#: what each model is, for legends (Pavlenko (2014): chain form (2.40)/(2.111), App. A/B program model)
MODEL_LABELS = {"nonlinear": "energy-consistent (nonlinear)", "nonlinear_chain": "chain form (2.40)/(2.111)",
                "consistent": "hand model, chain form", "program": "source's program model (App. A/B)",
                "thesis": "source's model as printed"}
FORCING_LABELS = {"physical": r"physical forcing $\delta\tau = b\,\delta\psi_1$",
                  "appendix": r"appendix forcing $\delta\tau = \delta\psi_1$"}
#: colour per model in the AFC and pole plots (the headline curve is tab:blue); the hand/program models reddish
MODEL_COLOURS = {"nonlinear": "tab:green", "nonlinear_chain": "0.45", "consistent": "darkred",
                 "program": "tab:red", "thesis": "tab:purple"}
#: the scene's forcing in words (the appendix forcing is the source's convention, for the comparison with it)
FORCING_WORDS = {"physical": "under the physical forcing δτ = b δψ1",
                 "appendix": "under the source's appendix forcing δτ = δψ1 (Pavlenko (2014), App. A/B)"}
HEADLINE = ("nonlinear", "physical")  # the energy-consistent model under the physical forcing


def _is_headline(h: HeadlineCurve, model: str, c: Curve) -> bool:
    """Whether curve ``c`` of ``model`` is the headline curve itself (same model, same forcing)."""
    return model == h.model and c.forcing == h.forcing


def grid(lin: LinearModel, start: float, stop: float, points: int) -> np.ndarray:
    """Log grid from start to stop plus 81 points within +-8 |Re lambda| of each lightly damped
    pole (damping ratio below 0.3) in range: the peaks are resolved whatever the base grid."""
    om = [np.geomspace(start, stop, points)]
    for lam in lin.poles():
        wn = abs(lam)
        if lam.imag > 0 and wn > 0 and abs(lam.real) / wn < 0.3 and start <= lam.imag <= stop:
            om.append(lam.imag + abs(lam.real) * np.linspace(-8, 8, 81))
    om = np.unique(np.concatenate(om))
    return om[(om >= start) & (om <= stop)]


PEAK_XATOL = 1e-6  # relative tolerance in omega of the bounded peak search


def peaks(lin: LinearModel, omega: np.ndarray, amp: np.ndarray, convention: str, scale: float) -> list[dict]:
    """Local maxima of the amplitude, each refined by a bounded search between its neighbours."""
    out = []
    for i in np.flatnonzero((amp[1:-1] > amp[:-2]) & (amp[1:-1] >= amp[2:])) + 1:
        res = minimize_scalar(lambda w: -abs(lin.response([w], convention)[0]) * scale,
                              bounds=(omega[i - 1], omega[i + 1]), method="bounded",
                              options={"xatol": PEAK_XATOL * omega[i]})
        out.append({"omega": float(res.x), "amplitude": float(-res.fun)})
    return out


def characteristic(lin: LinearModel, omega_range: tuple, convention: str, amplitude: float,
                   omega0: float) -> dict:
    """AFC/PFC of du for one linear model: grid, amplitude (m), phase (deg), peaks, A(omega0)."""
    scale = amplitude * lin.z_B
    om = grid(lin, *omega_range)
    n = len(lin.states)
    siso = control.ss(lin.A, lin.forcing(convention)[:, None], np.eye(n)[[lin.u_out]], 0)
    fr = control.frequency_response(siso, om)
    mag, phase = np.asarray(fr.magnitude).ravel() * scale, np.degrees(np.unwrap(np.asarray(fr.phase).ravel()))
    phase -= 360.0 * np.floor((phase[0] + 270.0) / 360.0)  # unwrapped, starting in [-270, 90): -180 for a negative gain
    w0 = lin.response([omega0], convention)[0] if np.isfinite(omega0) else np.nan
    max_real = float(lin.poles().real.max())
    return {
        "stable": max_real < 0, "max_real": max_real,
        "omega": om, "amplitude": mag, "phase_deg": phase,
        "peaks": peaks(lin, om, mag, convention, scale),
        "at_operating_speed": {"omega": omega0, "amplitude": abs(w0) * scale,
                               "phase_deg": float(np.degrees(np.angle(w0)))},
        "static_amplitude": float(abs(lin.response([0.0], convention)[0]) * scale),
        "forcing": convention,
    }


_P14 = "Pavlenko (2014)"


def _omega(description: str, symbol: str = "ω", **kw):
    return quantity("rad/s", symbol, description, beside="Hz", **kw)


def _amplitude(description: str, symbol: str = "A", **kw):
    return quantity("m", symbol, description, "µm", **kw)


def _phase():
    return quantity("deg", "φ(ω0)", "phase of the face gap at the operating speed")


@record
class Peak(Record):
    """A resonance peak of a model's AFC."""

    omega: float = _omega("resonance frequency of a model")
    amplitude: float = _amplitude("face-gap amplitude of a model")


@record
class AtSpeed(Record):
    """A model's response at the operating speed ω0."""

    omega: float = quantity("rad/s", "ω0", "operating speed of a model")
    amplitude: float = _amplitude("face-gap amplitude of a model")
    phase_deg: float = _phase()


@record
class Sampled(Record):
    """The curve on its frequency grid (rad/s; amplitude m, unwrapped phase deg): held for the tables and figures,
    not in results.json (afc_<model>.csv holds it), None in a loaded Result."""

    omega: np.ndarray | None = unsaved()
    amplitude: np.ndarray | None = unsaved()
    phase_deg: np.ndarray | None = unsaved()


@record
class Curve(Sampled):
    """The AFC/PFC of one model (:func:`characteristic`)."""

    stable: bool
    max_real: float = quantity("1/s", "max Re λ", "spectral abscissa of a model")
    peaks: list[Peak]
    at_operating_speed: AtSpeed
    static_amplitude: float = _amplitude("face-gap amplitude of a model")
    forcing: str


@record
class HeadlinePeak(Record):
    omega: float = _omega("resonance frequencies of the headline model", "ω_I, ω_II", headline=1)
    amplitude: float = _amplitude("face-gap amplitude at the resonances", "A_I, A_II", headline=2)


@record
class HeadlineAtSpeed(Record):
    omega: float = quantity("rad/s", "ω0", "operating speed", headline=3)
    amplitude: float = _amplitude("face-gap amplitude at the operating speed", "A(ω0)", headline=4)
    phase_deg: float = _phase()


@record
class HeadlineCurve(Sampled):
    """The headline curve: the energy-consistent model under the physical forcing, the one verdict."""

    model: str
    stable: bool
    max_real: float = quantity("1/s", "max Re λ", "spectral abscissa of the headline model", headline=6)
    peaks: list[HeadlinePeak]
    at_operating_speed: HeadlineAtSpeed
    static_amplitude: float = _amplitude("static face-gap amplitude", "A(0)", headline=5)
    forcing: str


@record
class FrequencyResult(TypedResult):
    """AFC/PFC of the face gap for each model (Pavlenko (2014), Figs 2.7, 2.11): amplitudes in metres for the
    forcing amplitude dpsi1a, frequencies in rad/s.  The top-level ``peaks`` and ``at_operating_speed`` are the
    first listed model's; ``head`` (results.json ``headline``) is the energy-consistent model under the physical
    forcing, whatever the scene lists."""

    title: str
    model: str
    forcing: str
    forcing_amplitude: float = quantity("1", "δψ_1a", "forcing amplitude, ratio of the discharge pressure",
                                        source=f"{_P14}, §2.6", headline=7)
    z_B: float = quantity("m", "z_B", "base gap of the amplitudes", "µm")
    peaks: list[Peak]
    at_operating_speed: AtSpeed
    #: the error estimate of :func:`accuracy` (its numbers are declared for every analysis: accuracy.**)
    accuracy: dict | None = optional(kw_only=True)
    head: HeadlineCurve = keyed("headline")
    models: dict[str, Curve]
    name = "frequency"

    @property
    def amplitude_at_operating_speed(self) -> float:
        """Face-gap amplitude of the first model at the operating speed omega0, m."""
        return self.at_operating_speed.amplitude

    def summary(self) -> str:
        """The verdict (the headline model under the physical forcing) and its headline numbers in display units, a
        line per resonance; below the validation line every other curve, each with its forcing (the source's
        appendix forcing, when the scene names it, is validation: it is not the machine's): the headline curve is
        shown once."""
        h = self.head
        q_omega, q_amp = QUANTITIES.find("peaks.0.omega"), QUANTITIES.find("peaks.0.amplitude")

        def curve(c) -> str:
            pk = ", ".join(f"{q_omega.text(p.omega)} with {q_amp.text(p.amplitude)}" for p in c.peaks)
            return f"peaks {pk or 'none'}; at the operating speed {q_amp.text(c.at_operating_speed.amplitude)}"

        label = f"{MODEL_LABELS.get(h.model, h.model)}, {h.forcing} forcing"
        lines = [f"frequency response: {label}: {'stable' if h.stable else 'UNSTABLE'}",
                 *QUANTITIES.lines(self.to_dict())]  # its resonances, A(ω0), A(0): each number once
        others = {m: c for m, c in self.models.items() if not _is_headline(h, m, c)}
        if others:
            forcing = FORCING_WORDS.get(self.forcing, self.forcing)
            judge = "its models and its forcing" if self.forcing == "appendix" else "its models"
            lines.append(f"  validation against the source ({judge} do not judge the machine), "
                         f"{forcing}, δψ_1a = {significant(self.forcing_amplitude)}:")
            lines += [f"    {MODEL_LABELS.get(m, m)}{'' if c.stable else ' (UNSTABLE)'}: {curve(c)}"
                      for m, c in others.items()]
        return "\n".join(lines)

    def _curves(self) -> dict:
        """The curves to draw and tabulate; ValueError for a Result loaded from results.json, which has none."""
        if self.head.omega is None:
            raise ValueError("frequency: a loaded Result holds no curves (results.json has the peaks; the curves "
                             "are in afc_<model>.csv of the run)")
        return self.models

    def tables(self) -> dict[str, dict]:
        curves = dict(self._curves())
        h = self.head
        if h.model not in curves or h.forcing != self.forcing:
            curves[f"headline_{h.model}_{h.forcing}"] = h
        q_omega, q_amp = QUANTITIES.find("peaks.0.omega"), QUANTITIES.find("peaks.0.amplitude")
        return {f"afc_{m}.csv": {f"omega [{q_omega.display}]": q_omega.shown(np.asarray(c.omega)),
                                 f"amplitude [{q_amp.display}]": q_amp.shown(np.asarray(c.amplitude)),
                                 "phase [deg]": c.phase_deg} for m, c in curves.items()}

    def _styles(self) -> list[tuple[str, dict, dict, str]]:
        """(key, curve, line style, legend label) per drawn curve: the headline (energy-consistent model,
        physical forcing) first and thick; unstable models thin dashed in red/grey shades; a curve that
        coincides with one drawn before it dotted with markers and said so."""
        out, drawn = [], []
        h = self.head
        curves = dict(self._curves())
        if h.model in curves and h.forcing == self.forcing:
            curves.pop(h.model)  # the headline is that same curve
        items = [("headline", h), *curves.items()]
        spare = iter(["tab:olive", "tab:brown", "tab:cyan", "tab:pink"])
        for key, c in items:
            model = h.model if key == "headline" else key
            label = MODEL_LABELS.get(model, model)
            if key == "headline":
                style = {"color": "tab:blue", "lw": 2.4, "zorder": 4} | ({} if c.stable else {"ls": "--"})
                label += f", {FORCING_LABELS.get(h.forcing, h.forcing)} (headline)"
            elif c.stable:
                style = {"color": MODEL_COLOURS.get(model) or next(spare), "lw": 1.5, "zorder": 3}
            else:
                style = {"color": MODEL_COLOURS.get(model) or next(spare), "lw": 0.9, "ls": "--", "zorder": 2}
            if key != "headline" and c.forcing != h.forcing:
                label += f", {c.forcing} forcing"
            if not c.stable:
                label += " — unstable"
            twin = next((lab for om, amp, lab in drawn if _coincide(om, amp, c.omega, c.amplitude)), None)
            if twin is not None:
                style |= {"ls": (0, (1.5, 2.5)), "lw": 2.0, "marker": "o", "ms": 4, "mfc": "none",
                          "markevery": 0.07, "zorder": 5}
                label += f"; same curve as {twin}"
            drawn.append((c.omega, c.amplitude, MODEL_LABELS.get(model, model)))
            out.append((key, c, style, label))
        return out

    def draw(self, ax) -> None:
        """The amplitude curves of every model with their peaks, the headline model first; the operating
        speed dotted and its amplitude marked; the frequency in its display unit (rad/s, Hz on top), the amplitude
        in its display unit (µm)."""
        fw, fa = self._axes(ax)
        for _key, c, style, label in self._styles():
            ax.semilogy(np.asarray(c.omega) * fw, np.asarray(c.amplitude) * fa, label=label, **style)
            for p in c.peaks:
                ax.plot(p.omega * fw, p.amplitude * fa, "o", ms=5, mec="w", mew=0.6, color=style["color"], zorder=6)
        a0 = self.head.at_operating_speed
        q_omega, q_amp = QUANTITIES.find("at_operating_speed.omega"), QUANTITIES.find("at_operating_speed.amplitude")
        ax.axvline(a0.omega * fw, color="k", ls=":", lw=1.0,
                   label=rf"operating speed $\omega_0$ = {q_omega.text(a0.omega)}")
        ax.plot(a0.omega * fw, a0.amplitude * fa, "D", color="k", ms=5, zorder=7,
                label=rf"$A(\omega_0)$ = {q_amp.text(a0.amplitude, 3)} (headline); dots: peaks")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5)

    def _axes(self, ax) -> tuple[float, float]:
        """Label ``ax``: the forcing frequency on x in the display unit of the resonance frequencies (rad/s, Hz
        on top), the gap amplitude on y in its display unit (µm); the factors from SI (rad/s, m) to them."""
        q_omega, q_amp = QUANTITIES.find("peaks.0.omega"), QUANTITIES.find("peaks.0.amplitude")
        fw = unit_axis(ax, r"frequency $\omega$", q_omega.unit, q_omega.declared, "x", q_omega.beside)
        return fw, unit_axis(ax, "gap amplitude $A_u$", q_amp.unit, q_amp.declared)

    def figures(self) -> dict[str, Figure]:
        from matplotlib.ticker import MultipleLocator

        fig, (a1, a2) = new_figure(figsize=(9.5, 7.8), nrows=2, sharex=True)
        self.draw(a1)
        a1.get_legend().remove()  # one legend for both axes, below them
        a1.set_xlabel("")  # the frequency is labelled below a2 (and on top of a1)
        fw = unit_axis(a2, r"frequency $\omega$", "rad/s", QUANTITIES.find("peaks.0.omega").declared, "x", "")
        for _key, c, style, _label in self._styles():
            a2.plot(np.asarray(c.omega) * fw, c.phase_deg, **style)
        a2.axvline(self.at_operating_speed.omega * fw, color="k", ls=":", lw=1.0)
        a2.grid(alpha=0.3)
        a2.set_ylabel("phase (unwrapped), deg")
        span = max(np.ptp(c.phase_deg) for c in self.models.values())
        a2.yaxis.set_major_locator(MultipleLocator(90 if span <= 720 else 180))
        fig.legend(*a1.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize=7.5,
                   frameon=False)
        forcing = self.forcing
        rest = ("" if self.head.forcing == forcing else
                f"\nthe other models under the {FORCING_LABELS.get(forcing, forcing)}, as in the source")
        fig.suptitle(f"{self.title}\nAFC/PFC of the face gap, forcing amplitude "
                     rf"$\delta\psi_{{1a}}$ = {self.forcing_amplitude:g} (Pavlenko (2014), Figs 2.7/2.11)"
                     f"{rest}", fontsize=9)
        return {"fig_afc.png": Figure(fig, "Amplitude and phase of the face-gap response (AFC): the headline "
                                           "energy-consistent model under the physical forcing (thick), the other "
                                           "models under the scene's forcing, unstable ones dashed and labelled; "
                                           "Pavlenko (2014), §2.6")}


#: every number of the frequency block (Pavlenko 2014, §2.6), from the fields: amplitudes of the face gap in m,
#: shown in µm
FrequencyResult.quantities = QUANTITIES = declarations(FrequencyResult)


def _coincide(om1, a1, om2, a2, rtol: float = 2e-3) -> bool:
    """Whether two amplitude curves agree to ``rtol`` over their common frequency range."""
    lo, hi = max(om1[0], om2[0]), min(om1[-1], om2[-1])
    w = om2[(om2 >= lo) & (om2 <= hi)]
    return len(w) > 1 and bool(np.all(np.abs(np.interp(w, om1, a1) / np.interp(w, om2, a2) - 1) < rtol))


def study(setup: Setup, models: list[str], convention: str, omega_range: tuple, title: str = "") -> FrequencyResult:
    """AFC of each named model; the first one gives the top-level peaks and A(omega0).  ``headline``
    holds the energy-consistent model under the physical forcing (dtau = b dpsi1), whatever the scene
    lists: the physically consistent result, the program model being the validation against the source."""
    d = setup.data
    raw = {}
    with progress.steps(len(models), "frequency response", "model", delay=progress.AFTER_S) as bar:
        for m in models:
            raw[m] = characteristic(setup.linear(m), omega_range, convention, d.forcing_amplitude, d.omega0)
            bar.tick(note=m)
    curves = {m: _curve(c, Curve) for m, c in raw.items()}
    first = curves[models[0]]
    model, forcing = HEADLINE
    head = raw[model] if model in raw and convention == forcing else characteristic(
        setup.linear(model), omega_range, forcing, d.forcing_amplitude, d.omega0)
    return FrequencyResult(
        title=title, model=models[0], forcing=convention, forcing_amplitude=d.forcing_amplitude,
        z_B=setup.dev.scales["z_B"], peaks=first.peaks, at_operating_speed=first.at_operating_speed,
        head=_curve(head, HeadlineCurve, model=model), models=curves)


def _curve(c: dict, cls: type, **more):
    """The curve ``c`` of :func:`characteristic` as the record ``cls`` with the fields ``more``, its sampled
    arrays kept."""
    sampled = ("omega", "amplitude", "phase_deg")
    saved = cls.from_dict(more | {k: v for k, v in c.items() if k not in sampled})
    return dataclasses.replace(saved, **{k: c[k] for k in sampled})


def exact_response(lin: LinearModel, omega: float, convention: str, digits: int = 34) -> complex:
    """du per unit dpsi1 at ``omega`` by an LU solve of (i omega I - A) x = b in ``digits``-digit
    arithmetic (mpmath) with the same double-precision A and b: the reference for the rounding error
    of :meth:`LinearModel.response`."""
    import mpmath as mp

    n = len(lin.states)
    with mp.workdps(digits):
        M = mp.matrix(n, n)
        for i in range(n):
            for j in range(n):
                M[i, j] = -mp.mpf(float(lin.A[i, j]))
            M[i, i] += mp.mpc(0, float(omega))
        b = mp.matrix([mp.mpf(float(v)) for v in lin.forcing(convention)])
        return complex(mp.lu_solve(M, b)[lin.u_out])


def peak_error(lin: LinearModel, omega: float, convention: str) -> tuple[float, float]:
    """Distance of a refined peak from the true maximum of |G|: one Newton step -g/g' on
    g = d|G|^2/d omega (dG/d omega = -i e_u (i omega I - A)^-2 b, exact; g' by a central difference
    of width PEAK_XATOL omega).  Returns (|step| / omega, relative amplitude lost by the step,
    |g'| step^2 / (4 |G|^2))."""
    n, b, j = len(lin.states), lin.forcing(convention), lin.u_out

    def g(w):
        M = 1j * w * np.eye(n) - lin.A
        x = np.linalg.solve(M, b)
        return 2.0 * np.real(np.conj(x[j]) * (-1j * np.linalg.solve(M, x))[j]), abs(x[j])

    h = PEAK_XATOL * omega
    g0, amp = g(omega)
    gp = (g(omega + h)[0] - g(omega - h)[0]) / (2 * h)
    step = abs(g0 / gp) if gp != 0 else float("inf")
    return step / omega, abs(gp) * step**2 / (4 * amp**2)


def accuracy(setup: Setup, curves: dict, convention: str) -> dict:
    """Error estimate of the main outputs of every model (peak frequencies and amplitudes, A(omega0),
    the static amplitude): the peak search's distance from the true maximum (:func:`peak_error`) and
    the rounding error of the response, double-precision LU against a 34-digit solve (:func:`exact_response`)."""
    loc, loss, rnd = [0.0], [0.0], [0.0]
    for m, c in curves.items():
        lin = setup.linear(m)
        for p in c.peaks:
            a, b = peak_error(lin, p.omega, convention)
            loc.append(a)
            loss.append(b)
        w0 = c.at_operating_speed.omega
        pts = [p.omega for p in c.peaks] + [0.0] + ([w0] if np.isfinite(w0) else [])
        got = lin.response(pts, convention)
        ref = np.array([exact_response(lin, w, convention) for w in pts])
        rnd.append(float(np.max(np.abs(got - ref) / np.abs(ref))))
    out = {"peak_frequency_max_relative_error": max(loc), "peak_amplitude_max_relative_loss": max(loss),
           "response_max_relative_rounding_error": max(rnd), "peak_search_xatol_relative": PEAK_XATOL,
           "operating_point_relative_residual": setup.static.max_residual}
    out["estimate"] = max(max(loc), max(loss), max(rnd))
    out["how"] = ("largest over the models of: a refined peak's distance from the true maximum (one Newton step "
                  "on d|G|^2/d omega with the exact derivative), the amplitude lost by it, and the rounding "
                  "error of the response at the peaks, omega0 and omega = 0 (double LU vs a 34-digit mpmath "
                  "solve); for the linear models as built (the static point they linearize has the relative "
                  "residual listed; python-control's curve uses the same LU without slycot, so it is no "
                  "independent check)")
    return out
