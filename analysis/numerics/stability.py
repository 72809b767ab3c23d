"""Poles, damping, Hurwitz determinants and stability maps (Pavlenko 2014, (2.73)-(2.75), (2.97)-(2.99)).

``verdict(lin)``: eigenvalues of the linear model, damping ratios, natural frequencies, the stability
margin (decay rate -max Re lambda, 1/s, and the smallest damping ratio), and the Hurwitz test of the
characteristic polynomial: coefficients a0..an in a scaled time p = omega_ref p~ (so that they are
not 1e-40 .. 1e-2 as in det N(p)), and the leading minors of the Hurwitz matrix (2.99), evaluated
exactly in rational arithmetic from those coefficients (their signs are reliable whatever the
dynamic range; positive scalings of p and of the polynomial do not change them).
``stability_map``: max Re lambda over a grid of two dynamic parameters, for the hand models
(constants recomputed at each point) or the nonlinear model (its exact Jacobian mapped over the
grid in one CasADi call).  The runner of ``analyses.stability`` is :func:`autobal.analyses.stability.run`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from fractions import Fraction

import numpy as np
import scipy.linalg
import scipy.optimize

from autobal.analysis.numerics.frequency import MODEL_COLOURS, MODEL_LABELS
from autobal.analysis.numerics.linearize import LinearModel, Setup, coefficient_table, jacobians, operator
from autobal.analysis.run import progress
from autobal.analysis.run.fields import Record, TypedResult, declarations, keyed, optional, quantity, record
from autobal.analysis.run.figures import Figure, record_axis
from autobal.analysis.run.quantities import Quantity, convert, lookup, significant
from autobal.analysis.run.result import new_figure, unit_axis
from autobal.models.dynamics import LONG_NAMES, DynamicData

OMEGA_REF = 1000.0  # rad/s, time scale of the reported polynomial coefficients


def hurwitz_minors(a) -> list[float]:
    """Leading principal minors Delta_1..Delta_n of the Hurwitz matrix (2.99), Delta_ij = a_{2j-i},
    of a0 p^n + ... + an, computed exactly (fractions) from the float coefficients."""
    a = [Fraction(float(x)) for x in a]
    n = len(a) - 1

    def coef(k):
        return a[k] if 0 <= k <= n else Fraction(0)

    H = [[coef(2 * (j + 1) - (i + 1)) for j in range(n)] for i in range(n)]
    return [float(_det([row[:k] for row in H[:k]])) for k in range(1, n + 1)]


def _det(M) -> Fraction:
    """Determinant by fraction-exact Gaussian elimination."""
    M = [row[:] for row in M]
    n, det = len(M), Fraction(1)
    for c in range(n):
        piv = next((r for r in range(c, n) if M[r][c] != 0), None)
        if piv is None:
            return Fraction(0)
        if piv != c:
            M[c], M[piv] = M[piv], M[c]
            det = -det
        det *= M[c][c]
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            if f:
                M[r] = [x - f * y for x, y in zip(M[r], M[c], strict=True)]
    return det


def verdict(lin: LinearModel, hurwitz: bool = True) -> dict:
    """Poles, damping ratios, natural frequencies, margin and (``hurwitz``) the Hurwitz test of one linear model
    (its exact determinants take milliseconds: the live explorer, autobal/explore.py, leaves them out)."""
    lam = lin.poles()
    lam = lam[np.lexsort((lam.imag, -lam.real))]  # least stable first
    wn = np.abs(lam)
    zeta = np.where(wn > 0, -lam.real / np.where(wn > 0, wn, 1), 1.0)
    unstable = lam.real > 0
    out = {
        "stable": bool(not unstable.any()),
        "poles": {"real": lam.real, "imag": lam.imag},
        "damping_ratio": zeta, "natural_frequency": wn,
        "unstable_modes": [{"real": float(x.real), "imag": float(abs(x.imag))} for x in lam[unstable] if x.imag >= 0],
        "margin": {"decay_rate": float(-lam.real.max()), "min_damping_ratio": float(zeta.min())},
    }
    if hurwitz:
        a = np.real(np.poly(lam / OMEGA_REF))  # monic, in p~ = p / omega_ref
        minors = hurwitz_minors(a)
        out["hurwitz"] = {"omega_ref": OMEGA_REF, "coefficients": a, "minors": minors,
                          "coefficients_positive": bool(np.all(a > 0)),
                          "negative_minors": [i + 1 for i, m in enumerate(minors) if m <= 0],
                          "stable": bool(np.all(a > 0) and all(m > 0 for m in minors))}
    return out


def _axis(ax) -> np.ndarray:
    lo, hi = float(ax.start), float(ax.stop)
    return np.geomspace(lo, hi, ax.points) if ax.scale == "log" else np.linspace(lo, hi, ax.points)


def max_real(setup: Setup, model: str, changes: list[dict]) -> np.ndarray:
    """max Re lambda (1/s) of ``model`` for each dict of changed dynamic data (short names)."""
    if model.startswith("nonlinear"):
        m = setup.nonlinear("chain" if model == "nonlinear_chain" else "energy")
        P = np.column_stack([setup.data.with_(**ch).vector() for ch in changes])
        J = np.array(jacobians(m).map(len(changes))(m.x0, m.w0, P)[0])  # n x (n m)
        n = len(m.states)
        A = J.reshape(n, len(changes), n).transpose(1, 0, 2)
        return np.linalg.eigvals(A).real.max(axis=1)
    out = []
    with progress.steps(len(changes), f"max Re lambda, {model} model", "point", delay=progress.AFTER_S) as bar:
        for ch in changes:  # one linearisation each (a bar once the grid takes more than progress.AFTER_S)
            lin = setup.linear(model, setup.data.with_(**ch))
            out.append(lin.poles().real.max())
            bar.tick()
    return np.array(out)


def stability_map(setup: Setup, xaxis, yaxis, model: str) -> dict:
    """max Re lambda over the (x, y) grid of two dynamic parameters (scenario key names)."""
    xs, ys = _axis(xaxis), _axis(yaxis)
    kx, ky = LONG_NAMES[xaxis.parameter], LONG_NAMES[yaxis.parameter]
    changes = [{kx: x, ky: y} for y in ys for x in xs]
    R = max_real(setup, model, changes).reshape(len(ys), len(xs))
    return {"x": {"parameter": xaxis.parameter, "values": xs, "nominal": getattr(setup.data, kx), "scale": xaxis.scale},
            "y": {"parameter": yaxis.parameter, "values": ys, "nominal": getattr(setup.data, ky), "scale": yaxis.scale},
            "max_real": R, "stable_fraction": float(np.mean(R < 0)),
            "restoring": _restoring(setup, model, xaxis, yaxis, xs, ys, R)}


def _restoring(setup, model, xaxis, yaxis, xs, ys, R) -> dict:
    """What the map says restores stability: along each axis through the nominal point (the other
    parameter nominal), the stable intervals; and the stable grid point nearest to nominal."""
    kx, ky = LONG_NAMES[xaxis.parameter], LONG_NAMES[yaxis.parameter]
    x0, y0 = getattr(setup.data, kx), getattr(setup.data, ky)
    lines = {}
    for ax, key, vals in ((xaxis, kx, xs), (yaxis, ky, ys)):
        lines[ax.parameter] = {"values": vals, **_scan(setup, model, key, vals)}

    def offset(v, v0, ax, vals):  # distance from nominal in decades (log) or in axis spans (linear)
        return math.log10(v / v0) if ax.scale == "log" and v0 > 0 else (v - v0) / (vals[-1] - vals[0])

    best = None
    for (iy, ix), val in np.ndenumerate(R):
        if val < 0:
            d = math.hypot(offset(xs[ix], x0, xaxis, xs), offset(ys[iy], y0, yaxis, ys))
            if best is None or d < best[0]:
                best = (d, xs[ix], ys[iy], val)
    nearest = None if best is None else {xaxis.parameter: best[1], yaxis.parameter: best[2], "max_real": best[3]}
    return {"along_axes": lines, "nearest_stable": nearest}


SCANNED = ("disc_chamber_volume", "cavity_volume", "rotor_damping", "stem_damping")


def single_parameter_scans(setup: Setup, model: str, points: int = 61) -> dict:
    """max Re lambda along each of V2, V3, c_z, c_x alone (the others nominal), over 1e-3..1e3 times
    the nominal value (c_x: 1e-3..1e2 times the stem's critical damping 2 sqrt(k_reg m0)); the
    stable intervals say which single change restores stability."""
    out = {}
    for name in SCANNED:
        key = LONG_NAMES[name]
        nominal = getattr(setup.data, key)
        if key == "c_x":
            if not setup.data.has_regulator:
                continue
            crit = 2 * math.sqrt(setup.data.k_reg * setup.data.m0)
            vals = np.geomspace(1e-3 * crit, 1e2 * crit, points)
        else:
            vals = np.geomspace(1e-3 * nominal, 1e3 * nominal, points)
        out[name] = {"nominal": nominal, "values": vals, **_scan(setup, model, key, vals)}
    return out


def _scan(setup: Setup, model: str, key: str, vals) -> dict:
    """max Re lambda of ``model`` along one dynamic parameter ``key`` (the others nominal) over the grid ``vals``,
    and its stable intervals, each ending at a root of max Re lambda."""
    r = max_real(setup, model, [{key: v} for v in vals])
    return {"max_real": r, "stable_intervals": _intervals(vals, r, lambda v: max_real(setup, model, [{key: v}])[0])}


def _intervals(vals, max_re, at=None) -> list[list[float]]:
    """The stable intervals (max Re lambda < 0) of a scan over the grid ``vals``.  A boundary between two grid
    points is the root of max Re lambda there (Brent's method on ``at(value) -> max Re lambda``, to 1e-6
    relative; with ``at`` None, the zero of the straight line between the two points), not the last stable
    grid point; an interval that reaches an end of the range ends at that end."""
    vals, max_re = np.asarray(vals, float), np.asarray(max_re, float)

    def boundary(i: int) -> float:  # where max Re lambda changes sign between vals[i] and vals[i + 1]
        a, b, fa, fb = vals[i], vals[i + 1], max_re[i], max_re[i + 1]
        if not (math.isfinite(fa) and math.isfinite(fb)):
            return float(a if fa < 0 else b)  # a failed point: the stable grid point
        if at is not None:
            return float(scipy.optimize.brentq(at, a, b, xtol=1e-12 * max(abs(a), abs(b)), rtol=1e-6))
        return float(a + fa / (fa - fb) * (b - a))

    stable = max_re < 0
    out, start = [], None
    for i, s in enumerate(stable):
        if s and start is None:
            start = float(vals[0]) if i == 0 else boundary(i - 1)
        if not s and start is not None:
            out.append([start, boundary(i - 1)])
            start = None
    if start is not None:
        out.append([start, float(vals[-1])])
    return out


_P14 = "Pavlenko (2014)"

#: name and display unit of each dynamic parameter a map or a scan varies (scene key); its SI unit is its field's
#: in DynamicData (models/dynamics.py), the one declaration
_PARAMETER_NAMES = {
    "rotor_mass": ("rotor mass", "kg"), "pushoff_stiffness": ("push-off stiffness", "MN/m"),
    "rotor_damping": ("rotor damping", "kN·s/m"), "bulk_modulus": ("bulk modulus", "MPa"),
    "disc_chamber_volume": ("disc-chamber volume", "cm³"), "cavity_volume": ("cavity volume", "cm³"),
    "stem_mass": ("regulator stem mass", "kg"), "spring_stiffness": ("regulator spring stiffness", "MN/m"),
    "stem_damping": ("stem damping", "N·s/m"), "valve_chamber_volume": ("valve-chamber volume", "cm³"),
    "membrane_chamber_volume": ("membrane-chamber volume", "cm³"), "seat_area": ("valve seat area", "mm²")}
_SI = {f.name: f.metadata["unit"].replace("**", "^") for f in dataclasses.fields(DynamicData)}
#: scene key -> the declaration of the dynamic parameter (its values in maps and scans)
PARAMETERS = {k: Quantity(k, _SI[LONG_NAMES[k]], LONG_NAMES[k], name, shown, source=f"{_P14}, App. A/B")
              for k, (name, shown) in _PARAMETER_NAMES.items()}
assert set(PARAMETERS) == set(LONG_NAMES)


def _scanned(name: str) -> str:
    """The keys holding values of the dynamic parameter ``name``: its scans, the map's lines and nearest point."""
    return (f"single_parameter.*.{name}.nominal single_parameter.*.{name}.values "
            f"single_parameter.*.{name}.stable_intervals maps.*.restoring.along_axes.{name}.values "
            f"maps.*.restoring.along_axes.{name}.stable_intervals maps.*.restoring.nearest_stable.{name}")


def _map_axis(path: str, block: dict | None) -> Quantity | None:
    """The declaration of a map axis' values and nominal value: the parameter the axis names."""
    m = re.fullmatch(r"(maps\.[^.]+\.[xy])\.(values|nominal)", path)
    q = PARAMETERS.get(lookup(block, m.group(1) + ".parameter", None)) if m and block is not None else None
    return None if q is None else dataclasses.replace(q, key=path, description=f"{q.description} on the map's axis")


def _re(**kw):
    return quantity("1/s", "Re λ", "real part of a pole (positive: an unstable mode)", source=f"{_P14}, Eq. (2.97)",
                    **kw)


def _im(**kw):
    return quantity("rad/s", "Im λ", "imaginary part of a pole, the mode's damped frequency", "rad/s", beside="Hz",
                    **kw)


@record
class Poles(Record):
    """The poles of a linear model, least stable first."""

    real: np.ndarray = _re()
    imag: np.ndarray = _im()

    @property
    def values(self) -> np.ndarray:
        """The poles as complex numbers, 1/s."""
        return np.asarray(self.real, float) + 1j * np.asarray(self.imag, float)


@record
class Mode(Record):
    """An unstable mode: a pole of the upper half-plane with a positive real part."""

    real: float = _re()
    imag: float = _im()


@record
class Margin(Record):
    decay_rate: float = quantity("1/s", "η", "decay rate −max Re λ (negative: the growth rate of an unstable model)")
    min_damping_ratio: float = quantity("1", "ζ_min", "smallest damping ratio")


@record
class Hurwitz(Record):
    """The Hurwitz test of the characteristic polynomial (Pavlenko 2014, Eqs. (2.97)-(2.99))."""

    omega_ref: float = quantity("rad/s", "ω_ref", "time scale of the characteristic polynomial p = ω_ref p~", "rad/s")
    coefficients: np.ndarray = quantity("1", "a_i", "coefficients of the monic characteristic polynomial in "
                                        "p~ = p/ω_ref", source=f"{_P14}, Eq. (2.97)")
    minors: list[float] = quantity("1", "Δ_k", "leading minors of the Hurwitz matrix, in p~",
                                   source=f"{_P14}, Eqs. (2.98)-(2.99)")
    coefficients_positive: bool
    negative_minors: list[int] = quantity("1", "k", "indices k of the Hurwitz minors Δ_k ≤ 0")
    stable: bool


@record
class ModelVerdict(Record):
    """Poles, damping, margin and Hurwitz test of one linear model (:func:`verdict`)."""

    stable: bool
    poles: Poles
    damping_ratio: np.ndarray = quantity("1", "ζ", "damping ratio −Re λ/|λ| of a pole")
    natural_frequency: np.ndarray = quantity("rad/s", "ω_n", "natural frequency |λ| of a pole", "rad/s", beside="Hz")
    unstable_modes: list[Mode]
    margin: Margin
    hurwitz: Hurwitz


@record
class HeadlineMargin(Record):
    decay_rate: float = quantity("1/s", "η", "decay rate −max Re λ of the energy-consistent model", headline=2)
    min_damping_ratio: float = quantity("1", "ζ_min", "smallest damping ratio of its modes", headline=4)


@record
class LeadingPole(Record):
    real: float = quantity("1/s", "Re λ", "real part of its least-stable pole")
    imag: float = quantity("rad/s", "Im λ", "frequency of its least-stable mode", "rad/s", headline=5, beside="Hz")


@record
class Headline(Record):
    """The one verdict: the energy-consistent model's, with its margin to the required decay rate."""

    model: str
    stable: bool
    margin: HeadlineMargin
    margin_to_required: float = quantity("1/s", "η − α", "margin to the required decay rate", headline=3)
    meets_requirement: bool
    leading_pole: LeadingPole
    unstable_modes: list[Mode]


@record
class MapAxis(Record):
    """An axis of a map: the dynamic parameter (scene key) and its values, in that parameter's unit
    (:data:`PARAMETERS`, declared through :func:`_map_axis`)."""

    parameter: str
    values: np.ndarray
    nominal: float
    scale: str


@record
class StabilityMap(Record):
    """max Re λ of a model over the grid of two dynamic parameters (:func:`stability_map`)."""

    x: MapAxis
    y: MapAxis
    max_real: np.ndarray = quantity("1/s", "max Re λ", "spectral abscissa over a map or a scan")
    stable_fraction: float = quantity("1", "", "fraction of the map's grid that is stable")
    #: per axis parameter its line through nominal, and the nearest stable point: keys are parameter names
    restoring: dict


@record
class StabilityResult(TypedResult):
    """Poles, damping, Hurwitz test and margin of each linear model, coefficient table, maps
    (Pavlenko (2014), Eqs. (2.73)-(2.75), (2.97)-(2.99)).  The top-level ``stable``, ``poles``, ``hurwitz`` and
    ``margin`` are the headline (energy-consistent) model's."""

    title: str
    model: str
    stable: bool
    poles: Poles
    hurwitz: Hurwitz
    margin: Margin
    required_decay_rate: float = quantity("1/s", "α", "required decay rate (the scene's; 0: none)", headline=1,
                                          key="decay_rate")
    models: dict[str, ModelVerdict]
    #: its key "headline"; Result.headline() is the headline rows
    head: Headline = keyed("headline")
    #: the hand model's constants beside the exact linearization's (linearize.coefficient_table): keys are names
    coefficients: dict
    maps: dict[str, StabilityMap] | None = optional()
    #: model -> dynamic parameter -> its scan (:func:`single_parameter_scans`)
    single_parameter: dict | None = optional()
    #: model -> the sentence on what restores its stability
    restoring: dict[str, str] | None = optional()
    accuracy: dict | None = optional()
    name = "stability"

    @property
    def decay_rate(self) -> float:
        """Stability margin of the headline model, -max Re lambda, 1/s (negative: unstable)."""
        return self.margin.decay_rate


    def verdict(self) -> tuple[bool, str]:
        """The headline (energy-consistent) model's: stable or not, its decay rate and its margin to the scene's
        required decay rate α (ok: stable with a decay rate of at least α)."""
        h, alpha = self.head, self.required_decay_rate
        decay, eta = h.margin.decay_rate, QUANTITIES.find("headline.margin.decay_rate")
        ok = bool(h.stable) and decay >= alpha
        words = f"disturbances decay at {eta.text(decay)}" if decay > 0 else f"disturbances GROW at {eta.text(-decay)}"
        if alpha > 0:
            words += (f", {eta.text(decay - alpha)} above the required {eta.text(alpha)}" if ok else
                      f", the required {eta.text(alpha)} is NOT met")
        return ok, f"{MODEL_LABELS[h.model]}: {'stable' if h.stable else 'UNSTABLE'}, {words}"

    def summary(self) -> str:
        lines = [f"stability: {self.verdict()[1]}", *QUANTITIES.lines(self.to_dict())]
        maps = self.maps or {}
        lines += _map_lines(maps, self.restoring or {}, [m for m in maps if m == HEADLINE])
        lines.append("  validation against the source (its models do not judge the machine):")
        for m, v in self.models.items():
            if m == HEADLINE:
                continue
            modes = ", ".join(_mode(x) for x in v.unstable_modes) or "none"
            minors = ", ".join(f"Δ{k}" for k in v.hurwitz.negative_minors) or "none"
            decay = v.margin.decay_rate
            rate = f"decays at {significant(decay)} 1/s" if decay > 0 else f"grows at {significant(-decay)} 1/s"
            lines.append(f"    {MODEL_LABELS.get(m, m)}: {'stable' if v.stable else 'UNSTABLE'}, {rate}; unstable "
                         f"modes: {modes}; Hurwitz minors ≤ 0: {minors}")
        lines += ["  " + x for x in _map_lines(maps, self.restoring or {}, [m for m in maps if m != HEADLINE])]
        lines.append("    K/T of the hand model vs the exact linearization (consistent mode = nonlinear_chain to "
                     "1e-9); differences:")
        lines += [f"      {k:5s} {v}" for k, v in self.coefficients["notes"].items()]
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        """Poles per model (frequencies in rad/s and Hz), the hand model's constants with their units, and the
        maps with the parameters in their display units; every header names its unit."""
        out = {}
        for m, v in self.models.items():
            out[f"poles_{m}.csv"] = {"real [1/s]": v.poles.real, "imag [rad/s]": v.poles.imag,
                                     "imag [Hz]": [convert(x, "rad/s", "Hz") for x in v.poles.imag],
                                     "damping_ratio [1]": v.damping_ratio,
                                     "natural_frequency [rad/s]": v.natural_frequency,
                                     "natural_frequency [Hz]": [convert(x, "rad/s", "Hz")
                                                                for x in v.natural_frequency]}
        co = self.coefficients
        columns = {m: [v.get(k) for k in co["names"]] for m, v in co["columns"].items() if not m.endswith("_status")}
        some = next(m for m in columns)
        units = [QUANTITIES.find(f"coefficients.columns.{some}.{k}").unit for k in co["names"]]
        out["coefficients.csv"] = ({"name": co["names"], "unit": units} | columns
                                   | {"note": [co["notes"].get(k, "") for k in co["names"]]})
        for m, mp in (self.maps or {}).items():
            qx, qy = PARAMETERS[mp.x.parameter], PARAMETERS[mp.y.parameter]
            X, Y = np.meshgrid(mp.x.values, mp.y.values)
            out[f"stability_map_{m}.csv"] = {f"{mp.x.parameter} [{qx.display}]": qx.shown(X.ravel()),
                                             f"{mp.y.parameter} [{qy.display}]": qy.shown(Y.ravel()),
                                             "max_real [1/s]": np.asarray(mp.max_real).ravel()}
        return out

    def draw(self, ax) -> None:
        """The poles of every model in the complex plane (symlog real axis, linear range set from the
        data); nested hollow markers so that coinciding poles of several models stay visible; the
        unstable half-plane shaded."""
        from matplotlib.ticker import NullLocator

        models = _headline_first(self.models)
        re = np.concatenate([np.asarray(v.poles.real, float) for v in models.values()])
        nz = np.abs(re[re != 0])
        lo = 10.0 ** math.floor(math.log10(nz.min())) if nz.size else 1.0
        hi = 10.0 ** math.ceil(math.log10(max(nz.max(), 10 * lo))) if nz.size else 10.0
        right = 10.0 ** math.ceil(math.log10(max(re.max(), lo))) * 3 if re.max() > 0 else 3 * lo
        ax.axvspan(0, right, color="tab:red", alpha=0.09, lw=0, label=r"unstable half-plane Re $\lambda$ > 0")
        fi = unit_axis(ax, r"Im $\lambda$", "rad/s", other="Hz")
        for i, (m, v) in enumerate(models.items()):
            mk, size = POLE_MARKERS[i % len(POLE_MARKERS)]
            label = MODEL_LABELS.get(m, m) + ("" if v.stable else " — unstable")
            ax.plot(v.poles.real, np.asarray(v.poles.imag, float) * fi, mk, ms=size, mfc="none", mew=1.3,
                    label=label, color="tab:blue" if m == "nonlinear" else MODEL_COLOURS.get(m, "tab:orange"),
                    zorder=3 + i)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xscale("symlog", linthresh=lo, linscale=0.6)
        ax.set_xlim(-1.5 * hi, right)
        step = max(1, math.ceil(math.log10(hi / lo) / 4))
        dec = [10.0 ** k for k in range(round(math.log10(lo)), round(math.log10(hi)) + 1, step)]
        ax.set_xticks([-d for d in reversed(dec)] + [0.0] + [d for d in dec if d <= right])
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xlabel(rf"Re $\lambda$, 1/s (symlog, linear within $\pm${lo:g})")
        record_axis(ax, "x", "1/s", "1/s")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5)

    def figures(self) -> dict[str, Figure]:
        from matplotlib import colormaps
        from matplotlib.colors import ListedColormap, SymLogNorm
        from matplotlib.lines import Line2D

        fig, ax = new_figure(figsize=(7.6, 5.6))
        self.draw(ax)
        ax.get_legend().remove()  # outside the data instead
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize=7.5,
                   frameon=False)
        fig.suptitle(f"{self.title}\npoles of the linearized models (energy-consistent first; nested "
                     "markers: coinciding poles)", fontsize=9)
        figs = {"fig_poles.png": Figure(fig, "Poles per model (right half-plane = unstable)")}
        maps = self.maps or {}
        if not maps:
            return figs
        # one diverging scale for every map, centred on zero, symmetric, logarithmic beyond linthresh
        allR = np.concatenate([np.asarray(mp.max_real, float).ravel() for mp in maps.values()])
        allR = np.abs(allR[np.isfinite(allR)])
        lim = float(allR.max()) if allR.size else 1.0
        lin = max(float(np.percentile(allR, 10)), lim * 1e-4, 1e-12) if allR.size else 1.0
        lin = 10.0 ** math.floor(math.log10(lin))
        norm = SymLogNorm(linthresh=lin, linscale=0.3, vmin=-lim, vmax=lim)
        # RdBu_r without its white middle: a stable cell is clearly blue, an unstable one clearly red
        cmap = ListedColormap(colormaps["RdBu_r"](np.r_[np.linspace(0.0, 0.4, 128), np.linspace(0.6, 1.0, 128)]))
        for m, mp in maps.items():
            fig, ax = new_figure(figsize=(6.8, 5.2))
            (fx, _, lx), (fy, _, ly) = axis_label(mp.x.parameter), axis_label(mp.y.parameter)
            X, Y = np.meshgrid(np.asarray(mp.x.values, float) / fx, np.asarray(mp.y.values, float) / fy)
            R = np.asarray(mp.max_real, float)
            cs = ax.pcolormesh(X, Y, R, cmap=cmap, norm=norm, shading="auto")
            fig.colorbar(cs, ax=ax, label=r"max Re $\lambda$, 1/s (blue: stable, red: unstable)")
            handles = []
            if np.nanmin(R) < 0 < np.nanmax(R):
                ax.contour(X, Y, R, levels=[0.0], colors="k", linewidths=1.8)
                handles.append(Line2D([], [], color="k", lw=1.8, label=r"stability boundary max Re $\lambda$ = 0"))
            st = ax.plot(mp.x.nominal / fx, mp.y.nominal / fy, "*", color="gold", mec="k", ms=16,
                         clip_on=False, zorder=10, label="scene (nominal)")
            handles += st
            for a, setter in ((mp.x, ax.set_xscale), (mp.y, ax.set_yscale)):
                if a.scale == "log":
                    setter("log")
            ax.set_xlabel(lx)
            ax.set_ylabel(ly)
            verdict = self.models[m].stable if m in self.models else None
            tag = "" if verdict is None else (" (stable at nominal)" if verdict else " (unstable at nominal)")
            fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=8, frameon=False)
            ax.set_title(f"{self.title}\nstability map, {MODEL_LABELS.get(m, m)}{tag}; "
                         "colour scale shared by the maps", fontsize=8)
            figs[f"fig_stability_map_{m}.png"] = Figure(
                fig, f"Stability map of the {m.replace('_', ' ')} model: largest real part of the poles over two "
                "parameters, the nominal design marked")
        return figs


_SCANS = "maps.*.restoring.along_axes.*.max_real maps.*.restoring.nearest_stable.max_real single_parameter.*.*.max_real"
StabilityResult.quantities = QUANTITIES = declarations(
    StabilityResult,
    Quantity("coefficients.columns.*.K*", "1", "K_i", "gain of the hand model (2.43), per model and mode",
             source=f"{_P14}, Eqs. (2.44), (2.169), App. A/B"),
    Quantity("coefficients.columns.*.T* coefficients.columns.*.tau*", "s", "T_i, τ_i",
             "time constant of the hand model (2.43), per model and mode", "ms",
             source=f"{_P14}, Eqs. (2.44), (2.169), App. A/B"),
    Quantity("coefficients.columns.*.zeta*", "1", "ζ1, ζ2", "damping ratio of the hand model's rotor and stem",
             source=f"{_P14}, Eq. (2.44)"),
    Quantity("coefficients.extra.*.N0[*]", "1", "N0", "entry of the exact operator the hand model (2.101) lacks"),
    Quantity("coefficients.extra.*.N1[*]", "s", "N1", "entry of p in the exact operator the hand model lacks",
             "s"),
    Quantity("coefficients.extra.*.N2[*]", "s^2", "N2", "entry of p² in the exact operator the hand model lacks"),
    Quantity(_SCANS, "1/s", "max Re λ", "spectral abscissa over a map or a scan"),
    *(Quantity(_scanned(k), q.unit, q.symbol, f"{q.description}: values scanned", q.declared)
      for k, q in PARAMETERS.items()),
    resolve=_map_axis,
)



#: marker and size per model in the pole plot: nested hollow markers keep coinciding poles visible
POLE_MARKERS = (("o", 12), ("s", 9), ("D", 7), ("x", 4.5), ("+", 9), ("^", 4))

def _tex(symbol: str) -> str:
    """A parameter's symbol as mathematics: "k_pr" -> "$k_{pr}$", "V2" -> "$V_{2}$"."""
    base, sub = re.fullmatch(r"([A-Za-z]+?)_?([a-z0-9]*)", symbol).groups()
    return f"${base}_{{{sub}}}$" if sub else f"${base}$"


def axis_label(parameter: str) -> tuple[float, str, str]:
    """(factor, unit, axis label) of a map parameter given by its scenario key (``cavity_volume``).

    Parameters
    ----------
    parameter : str
        Scenario key of a dynamic parameter (a key of ``LONG_NAMES``).

    Returns
    -------
    (float, str, str)
        SI value / factor is the value shown; the unit shown (its declaration's display unit); the label
        "name symbol, unit".
    """
    q = PARAMETERS[parameter]
    return 1.0 / convert(1.0, q.unit, q.display), q.display, f"{q.description} {_tex(q.symbol)}, {q.display}"


HEADLINE = "nonlinear"  # the energy-consistent model: the one verdict; the others are the source's (validation)


def _mode(x: Mode) -> str:
    """An unstable mode as 'Re ± Im i 1/s (f Hz)'."""
    hz = significant(convert(x.imag, "rad/s", "Hz"))
    return f"{significant(x.real)} ± {significant(x.imag)}i 1/s ({hz} Hz)"


def _span(q: Quantity, a: float, b: float) -> str:
    """An interval of parameter values in the display unit: '0.1000 to 199.5 cm³'."""
    return f"{significant(q.shown(a))} to {q.text(b)}"


def _map_lines(maps: dict[str, StabilityMap], restoring: dict[str, str], models: list[str]) -> list[str]:
    """The summary lines of the maps of ``models``: the grid's stable share, each axis alone, what restores."""
    lines = []
    for m in models:
        mp = maps[m]
        qx, qy = PARAMETERS[mp.x.parameter], PARAMETERS[mp.y.parameter]
        lines.append(f"  map, {MODEL_LABELS.get(m, m)}: {qx.description} {qx.symbol} × {qy.description} "
                     f"{qy.symbol}, stable on {100 * mp.stable_fraction:.0f} % of the grid")
        for name, line in mp.restoring["along_axes"].items():
            q = PARAMETERS[name]
            iv = " or ".join(_span(q, a, b) for a, b in line["stable_intervals"]) or "no value in the range"
            lines.append(f"    {q.description} {q.symbol} alone (the other nominal): stable for {iv}")
        if m in restoring:
            lines.append(f"    restores stability: {restoring[m].removeprefix(m + ': ')}")
    return lines


def _headline_first(models: dict) -> dict:
    """The models with the energy-consistent one first (the headline; the source's models validate)."""
    return dict(sorted(models.items(), key=lambda kv: kv[0] != HEADLINE))


def study(setup: Setup, models: list[str], smap=None, title: str = "", decay_rate: float = 0.0) -> StabilityResult:
    """Verdict of each named model under ``models``; the top-level keys (``stable``, ``poles``, ``margin``,
    ``hurwitz``) and ``headline`` are the energy-consistent model's, the one verdict of the analysis (the
    source's models validate, they do not judge the machine), with its margin to the required ``decay_rate``
    (1/s); and the optional maps with their single-parameter scans."""
    res = {m: ModelVerdict.from_dict(verdict(setup.linear(m))) for m in models}
    head = res.get(HEADLINE) or ModelVerdict.from_dict(verdict(setup.linear(HEADLINE)))
    real, imag = head.poles.real, head.poles.imag
    upper = np.flatnonzero(imag >= 0)
    lead = upper[np.argmax(real[upper])]  # the least-stable pole of the upper half-plane
    decay = head.margin.decay_rate
    maps = scans = restoring = None
    if smap is not None:
        maps = {m: StabilityMap.from_dict(stability_map(setup, smap.x, smap.y, m)) for m in smap.models}
        scans = {m: single_parameter_scans(setup, m) for m in smap.models}
        restoring = {m: _statement(m, res.get(m), scans[m], maps[m]) for m in smap.models}
    return StabilityResult(
        title=title, model=HEADLINE, stable=head.stable, poles=head.poles, hurwitz=head.hurwitz, margin=head.margin,
        required_decay_rate=float(decay_rate), models=res,
        head=Headline(model=HEADLINE, stable=head.stable,
                          margin=HeadlineMargin(head.margin.decay_rate, head.margin.min_damping_ratio),
                          margin_to_required=decay - decay_rate,
                          meets_requirement=bool(head.stable and decay >= decay_rate),
                          leading_pole=LeadingPole(float(real[lead]), float(imag[lead])),
                          unstable_modes=head.unstable_modes),
        coefficients=coefficient_table(setup), maps=maps, single_parameter=scans, restoring=restoring)


def _statement(model: str, v: ModelVerdict | None, scans: dict, mp: StabilityMap) -> str:
    """One sentence: which change restores stability of ``model`` (its verdict ``v``, None if not computed), read
    off its scans and map (display units)."""
    if v is not None and v.stable:
        return f"{model}: stable as given (decay rate {significant(v.margin.decay_rate)} 1/s)"
    single = [f"{PARAMETERS[k].description} {PARAMETERS[k].symbol} in "
              + " or ".join(_span(PARAMETERS[k], a, b) for a, b in s["stable_intervals"])
              for k, s in scans.items() if s["stable_intervals"]]
    ns = mp.restoring["nearest_stable"]
    text = f"{model}: " + ("a single change restores stability: " + "; ".join(single) if single else
                           "no single change of " + ", ".join(PARAMETERS[k].description for k in scans) +
                           " within 1e-3..1e3 × nominal restores stability")
    if ns:
        (kx, qx), (ky, qy) = ((a.parameter, PARAMETERS[a.parameter]) for a in (mp.x, mp.y))
        text += (f"; on the map the nearest stable point is {qx.symbol} = {qx.text(ns[kx])} with {qy.symbol} = "
                 f"{qy.text(ns[ky])}, stable on {100 * mp.stable_fraction:.0f} % of the map")
    else:
        text += "; nowhere stable on the map"
    return text


def pencil(N0: np.ndarray, N1: np.ndarray, N2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(E, A) of the first-order descriptor form of N(p) q = N0 q + N1 q' + N2 q'' (a velocity state
    for every coordinate with a second derivative): its finite generalized eigenvalues are the roots
    of det N(p) (2.68)/(2.93)."""
    n = N0.shape[0]
    mech = [j for j in range(n) if np.any(N2[:, j] != 0)]
    col, m = {}, 0
    for j in range(n):
        col[j], m = m, m + (2 if j in mech else 1)
    E, A = np.zeros((m, m)), np.zeros((m, m))
    for row, j in enumerate(mech):  # kinematic rows d(q_j)/dt = q_j'
        E[row, col[j]] = A[row, col[j] + 1] = 1.0
    for r in range(n):
        row = len(mech) + r
        for j in range(n):
            A[row, col[j]] -= N0[r, j]
            if j in mech:
                A[row, col[j] + 1] -= N1[r, j]
                E[row, col[j] + 1] += N2[r, j]
            else:
                E[row, col[j]] += N1[r, j]
    return E, A


def pole_errors(setup: Setup, name: str) -> dict:
    """Error of the poles of one model: eigenpair residuals ||(A - lambda I) v|| / (||A|| ||v||), the
    first-order bound kappa(lambda) residual ||A|| / |lambda| (kappa = 1 / |y^H x|, unit left and right
    eigenvectors), and the relative distance to the same pole computed independently as a generalized
    eigenvalue (QZ) of the descriptor pencil: E, A of (2.43)/(2.101) for the hand models, the pencil of the
    nonlinear model's implicit rows N(p) (linearize.operator) for the exact linearizations."""
    A = setup.linear(name).A
    lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
    norm = np.linalg.norm(A, 2)
    resid = np.linalg.norm(A @ vr - vr * lam, axis=0) / (norm * np.linalg.norm(vr, axis=0))
    kappa = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0) / np.abs(np.sum(np.conj(vl) * vr, axis=0))
    bound = kappa * resid * norm
    if name.startswith("nonlinear"):
        E, Ad = pencil(*operator(setup.nonlinear("chain" if name == "nonlinear_chain" else "energy"))[:3])
    else:
        E, Ad = setup.constants(name).descriptor()[:2]
    mu = scipy.linalg.eig(Ad, E, right=False)
    mu = mu[np.isfinite(mu)]
    if len(mu) == len(lam):
        from scipy.optimize import linear_sum_assignment

        i, j = linear_sum_assignment(np.abs(lam[:, None] - mu[None, :]))
        diff = float(np.max(np.abs(lam[i] - mu[j]) / np.abs(lam[i])))
    else:
        diff = math.nan
    return {"max_residual": float(resid.max()), "max_condition": float(kappa.max()),
            "max_relative_bound": float(np.max(bound / np.abs(lam))), "descriptor_max_relative_difference": diff,
            # the sign of every real part is certain when it exceeds its own first-order error bound
            "signs_certain": bool(np.all(np.abs(lam.real) > bound))}


def accuracy(setup: Setup, models: list[str]) -> dict:
    """Error estimate of the poles of every model at the operating point (:func:`pole_errors`)."""
    per = {m: pole_errors(setup, m) for m in models}
    diffs = [v["descriptor_max_relative_difference"] for v in per.values()]
    out = {"models": per,
           "max_relative_bound": max(v["max_relative_bound"] for v in per.values()),
           "signs_certain": all(v["signs_certain"] for v in per.values())}
    if all(np.isfinite(diffs)):
        out["estimate"] = float(max(diffs))
        out["how"] = ("largest relative difference of a pole between the eigenvalues of the state matrix (QR) and "
                      "the generalized eigenvalues (QZ) of the descriptor pencil (E, A) of (2.101), i.e. the "
                      "roots of det N(p), over the models at the operating point; max_relative_bound is the "
                      "first-order bound condition x eigenpair residual x ||A|| / |lambda|; the maps use the "
                      "same eigensolver and are not checked separately")
    else:
        out["estimate"] = out["max_relative_bound"]
        out["how"] = ("first-order bound condition x eigenpair residual x ||A|| / |lambda| on the poles (the "
                      "descriptor pencil has a different number of finite roots, so no independent comparison)")
    return out
