"""The standards the reports judge a rotor by: one clause-cited function per rule, each with its hand-calculated test
(tests/test_standards.py); the reports call these and never re-derive them.

* API 684 (2005) (the tutorial of API's rotordynamic standard paragraphs) and API 617 (2014) (8th edition, Part 1,
  the lateral analysis): the amplification factor AF = N_c/(N_2 - N_1) read off the half-power points (0.707 of
  the peak) of the computed unbalance response (:func:`half_power_readings`, :func:`amplification_factor`); the
  separation margin SM measured from the operating speed range's boundary (:func:`separation_margin`); the margin
  required for that AF (:func:`required_separation_margin`) and the check of one critical speed against it
  (:func:`margin_check`).
* ISO 21940-11 (2016), balance quality grades: G = e_per Omega, the permissible specific unbalance (eccentricity)
  e_per = G/Omega and the permissible residual unbalance U_per = e_per m (:func:`balance_grade`,
  :func:`permissible_eccentricity`, :func:`permissible_unbalance`).

Speeds are in any one unit (rad/s in the toolkit), margins in per cent as the standards state them, G in m/s,
e_per in m, U_per in kg m.  The clause numbers of the standards' editions are not quoted here: each function names
the standard, its edition and the quantity it computes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass

import numpy as np

from autobal.analysis.run.fields import Record, optional, record

API_AF = "API 684 (2005); API 617 (2014), Part 1, lateral analysis: amplification factor"
API_SM = "API 684 (2005); API 617 (2014), Part 1, lateral analysis: separation margin"
ISO_G = "ISO 21940-11 (2016), balance quality grade"

#: below this amplification factor a response is critically damped and needs no separation margin (API 684 (2005),
#: API 617 (2014))
AF_CRITICALLY_DAMPED = 2.5
HALF_POWER = 1 / math.sqrt(2)  # the half-power points: 0.707 of the peak amplitude


# ---- API 684 (2005) / API 617 (2014): amplification factor from the unbalance response ----------------------------

@dataclass(frozen=True)
class HalfPower:
    """The reading of one critical speed off a computed unbalance response (API 684 (2005), amplification factor).

    ``critical_speed`` is the speed the reading was asked for (an eigenvalue's); ``peak_speed`` N_c is where the
    response peaks, ``lower``/``upper`` N_1 < N_c < N_2 where it is 0.707 of that peak; ``factor`` AF = N_c/(N_2 -
    N_1), None with the reason in ``status`` when the response gives no half-power points (no peak of its own, or
    it does not fall to 0.707 of the peak within the range: a heavily damped response, treated as critically
    damped) or the mode is undamped (``undamped``: AF is infinite)."""

    critical_speed: float
    peak_speed: float | None = None
    peak: float | None = None
    lower: float | None = None
    upper: float | None = None
    factor: float | None = None
    status: str | None = None
    undamped: bool = False


def amplification_factor(peak_speed: float, lower: float, upper: float) -> float:
    """AF = N_c/(N_2 - N_1) (API 684 (2005); API 617 (2014), Part 1: amplification factor).

    Parameters
    ----------
    peak_speed : float
        N_c, the speed of the peak of the unbalance response (the critical speed).
    lower, upper : float
        N_1 < N_c < N_2, the speeds where the response is 0.707 of the peak (the half-power points), in the unit
        of ``peak_speed``.

    Returns
    -------
    float
        AF, dimensionless.
    """
    if not lower < peak_speed < upper:
        raise ValueError(f"the half-power points must enclose the peak: {lower:g} < {peak_speed:g} < {upper:g}")
    return peak_speed / (upper - lower)


def _bisect(g: Callable[[float], float], a: float, b: float, xtol: float) -> float:
    """The root of ``g`` in [a, b] (``g`` changes sign there) to within ``xtol``, by bisection: a response read
    at a few dozen speeds costs less than importing scipy.optimize (0.4 s, in every spin-up run)."""
    ga = g(a)
    while b - a > xtol:
        m = 0.5 * (a + b)
        gm = g(m)
        a, b, ga = (m, b, gm) if (gm < 0) == (ga < 0) else (a, m, ga)
    return 0.5 * (a + b)


def _golden_max(f: Callable[[float], float], a: float, b: float, xtol: float) -> tuple[float, float]:
    """The maximum of ``f`` on [a, b] (one maximum there) to within ``xtol`` by golden-section search: (x, f(x))."""
    r = (math.sqrt(5) - 1) / 2
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    while b - a > xtol:
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = f(d)
    return (c, fc) if fc >= fd else (d, fd)


def half_power_readings(response: Callable[[np.ndarray], np.ndarray], critical_speeds, high: float,
                        low: float = 0.0, points: int = 4001, undamped=()) -> list[HalfPower]:
    """Read every critical speed's amplification factor off a computed steady unbalance response (API 684 (2005);
    API 617 (2014), Part 1: AF = N_c/(N_2 - N_1) at the half-power points, 0.707 of the peak).

    The response is sampled on ``points`` speeds over [low, high]; each critical speed takes the nearest local
    maximum (a peak nearer another critical speed is that one's: the critical speed then has no peak of its own);
    the peak is refined by a golden-section search between its neighbouring samples and each half-power point by
    bisection between the samples that bracket 0.707 of the peak.  Walking away from the peak, a response that rises
    above the peak, or reaches the end of the range, before it falls to 0.707 of the peak has no half-power point on
    that side: no AF (a heavily damped or merged response, treated as critically damped).

    Parameters
    ----------
    response : callable
        Speeds (array) -> steady amplitude of the unbalance response (array, any unit).
    critical_speeds : sequence of float
        The speeds to read (the model's critical speeds), in the unit of ``low`` and ``high``.
    high, low : float
        The speed range the response is valid over.
    points : int
        Samples of the response.
    undamped : sequence of bool, optional
        Per critical speed: an undamped mode (its peak is infinite: AF is not a number).

    Returns
    -------
    list of HalfPower
        One reading per critical speed, in its order.
    """
    critical_speeds = [float(c) for c in critical_speeds]
    undamped = list(undamped) or [False] * len(critical_speeds)
    w = np.linspace(low, high, points)
    a = np.asarray(response(w), float) if not all(undamped) else np.zeros(points)  # an undamped peak is infinite
    peaks = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    # each peak belongs to the critical speed nearest it
    owner = {int(i): min(range(len(critical_speeds)), key=lambda k: abs(critical_speeds[k] - w[i]))
             for i in peaks} if critical_speeds else {}
    out = []
    for k, wc in enumerate(critical_speeds):
        if undamped[k]:
            out.append(HalfPower(wc, status="an undamped mode: its peak and AF are infinite", undamped=True))
            continue
        mine = [i for i in peaks if owner[int(i)] == k]
        if not mine:
            near = f" (its response merges into the peak at {w[peaks[np.argmin(abs(w[peaks] - wc))]]:.4g})" \
                if peaks.size else ""
            out.append(HalfPower(wc, status="no peak of its own in the unbalance response" + near + ": no AF, "
                                 "treated as critically damped"))
            continue
        i = max(mine, key=lambda j: a[j])
        x, top = _golden_max(lambda x: float(np.asarray(response(np.array([x])))[0]), w[i - 1], w[i + 1],
                             1e-12 * max(abs(w[i]), 1.0))
        wp, peak = (float(x), float(top)) if top > a[i] else (float(w[i]), float(a[i]))
        level = HALF_POWER * peak

        def g(x, level=level):
            return float(np.asarray(response(np.array([x])))[0]) - level

        side, why = [], []
        for step, name in ((-1, "below"), (1, "above")):  # the first sample under 0.707 of the peak brackets N_1, N_2
            j, prev, found = (i if (w[i] - wp) * step > 0 else i + step), wp, None
            while 0 <= j < points and a[j] <= peak:
                if a[j] < level:
                    found = _bisect(g, *sorted((w[j], prev)), xtol=1e-12 * abs(wp))
                    break
                prev, j = w[j], j + step
            side.append(found)
            if found is None:
                why.append(f"{name} it: the response rises into a higher peak first" if 0 <= j < points else
                           f"{name} it: the response stays above 0.707 of the peak to the end of the range "
                           f"({low:.4g} to {high:.4g})")
        lo, hi = side
        if why:
            out.append(HalfPower(wc, wp, peak, lo, hi, status="no half-power point " + "; ".join(why) + ": no AF, "
                                 "treated as critically damped"))
            continue
        out.append(HalfPower(wc, wp, peak, lo, hi, amplification_factor(wp, lo, hi)))
    return out


# ---- API 684 (2005) / API 617 (2014): separation margin ---------------------------------------------------------

def separation_margin(critical_speed: float, min_speed: float, max_continuous_speed: float | None = None) -> float:
    """SM, % (API 684 (2005); API 617 (2014), Part 1: separation margin), measured from the operating speed range's
    boundary: a critical speed N_c below the minimum operating speed N_min has SM = 100 (N_min - N_c)/N_min, one
    above the maximum continuous speed N_mc SM = 100 (N_c - N_mc)/N_mc; one within the range a negative SM (the
    nearer boundary's formula).

    Parameters
    ----------
    critical_speed : float
        N_c.
    min_speed, max_continuous_speed : float
        N_min <= N_mc, the operating speed range (one service speed: N_min = N_mc, the default).

    Returns
    -------
    float
        SM, per cent.
    """
    n_mc = min_speed if max_continuous_speed is None else max_continuous_speed
    if not 0 < min_speed <= n_mc:
        raise ValueError(f"the operating speed range must be positive and ordered: {min_speed:g} to {n_mc:g}")
    below, above = (min_speed - critical_speed) / min_speed, (critical_speed - n_mc) / n_mc
    if critical_speed < min_speed:
        return 100 * below
    if critical_speed > n_mc:
        return 100 * above
    return 100 * max(below, above)


def required_separation_margin(factor: float | None, below: bool) -> float:
    """The separation margin the standard requires, % (API 684 (2005); API 617 (2014), Part 1: separation margin):
    none for AF < 2.5 (the response is critically damped); for AF >= 2.5 min(16, 17 (1 - 1/(AF - 1.5))) for a
    critical speed below the minimum operating speed and min(26, 10 + 17 (1 - 1/(AF - 1.5))) for one above the
    maximum continuous speed.  (Earlier editions banded AF, with fixed margins from 2.5 to 3.55; these continuous
    forms replace them.)

    Parameters
    ----------
    factor : float or None
        AF (``math.inf`` for an undamped mode; None: no AF could be read, treated as critically damped).
    below : bool
        The critical speed lies below the operating speed range (else above it).

    Returns
    -------
    float
        The required SM, per cent (0: none required).
    """
    if factor is None or factor < AF_CRITICALLY_DAMPED:
        return 0.0
    rise = 17 * (1 - 1 / (factor - 1.5))
    return min(16.0, rise) if below else min(26.0, 10 + rise)


def margin_check(reading: HalfPower, min_speed: float | None, max_continuous_speed: float | None = None) -> dict:
    """One critical speed against the operating speed range (API 684 (2005); API 617 (2014), Part 1): its AF
    (:func:`half_power_readings`), its SM from the range (:func:`separation_margin`; the critical speed is the
    response's peak N_c, the eigenvalue's where the response has no peak of its own), the SM required for that AF
    (:func:`required_separation_margin`) and whether it is kept.

    Parameters
    ----------
    reading : HalfPower
        The critical speed's reading off the unbalance response.
    min_speed, max_continuous_speed : float or None
        N_min <= N_mc, the operating speed range (N_mc None: one service speed); N_min None: no operating speed is
        known, so no SM (the AF alone).

    Returns
    -------
    dict
        ``amplification_factor``, ``response_peak_speed_rad_s``, ``half_power_speeds_rad_s`` (N_1, N_2),
        ``separation_margin_pct``, ``required_separation_margin_pct``, ``separation_margin_ok``; the reason beside
        each that is None (``*_status``).
    """
    out = {"amplification_factor": reading.factor, "response_peak_speed_rad_s": reading.peak_speed,
           "half_power_speeds_rad_s": None if reading.factor is None else [reading.lower, reading.upper]}
    if reading.status:
        out |= {"amplification_factor_status": reading.status, "half_power_speeds_rad_s_status": reading.status}
        if reading.peak_speed is None:
            out["response_peak_speed_rad_s_status"] = reading.status
    if min_speed is None:
        why = "no operating speed is known: no separation margin"
        return out | dict.fromkeys(("separation_margin_pct", "required_separation_margin_pct",
                                    "separation_margin_ok")) | {
            f"{k}_status": why for k in ("separation_margin_pct", "required_separation_margin_pct",
                                         "separation_margin_ok")}
    n_mc = min_speed if max_continuous_speed is None else max_continuous_speed
    nc = reading.critical_speed if reading.peak_speed is None else reading.peak_speed
    sm = separation_margin(nc, min_speed, n_mc)
    below = nc < min_speed or (nc <= n_mc and nc - min_speed < n_mc - nc)
    req = required_separation_margin(math.inf if reading.undamped else reading.factor, below)
    return out | {"separation_margin_pct": sm, "required_separation_margin_pct": req,
                  "separation_margin_ok": bool(sm >= req)}


@record
class Margin(Record):
    """The block of :func:`margin_check` as a record: its keys in its order, the reason beside each null (declared by
    :func:`margin_quantities`)."""

    amplification_factor: float | None
    response_peak_speed_rad_s: float | None
    half_power_speeds_rad_s: list[float] | None
    amplification_factor_status: str | None = optional()
    half_power_speeds_rad_s_status: str | None = optional()
    response_peak_speed_rad_s_status: str | None = optional()
    _: KW_ONLY
    separation_margin_pct: float | None
    required_separation_margin_pct: float | None
    separation_margin_ok: bool | None
    separation_margin_pct_status: str | None = optional()
    required_separation_margin_pct_status: str | None = optional()
    separation_margin_ok_status: str | None = optional()


def margin_quantities(prefix: str = "", headline: bool = False) -> tuple:
    """The declarations (:class:`autobal.analysis.run.quantities.Quantity`) of the keys :func:`margin_check` writes,
    each key under ``prefix`` ("rotor.", "critical_speeds.margins[]."), with the standard as its source."""
    from autobal.analysis.run.quantities import Quantity

    return (Quantity(f"{prefix}amplification_factor", "1", "AF", "amplification factor N_c/(N_2 − N_1) at the "
                     "half-power points of the unbalance response", source=API_AF, headline=headline),
            Quantity(f"{prefix}separation_margin_pct", "%", "SM", "separation margin from the operating speed",
                     source=API_SM, headline=headline),
            Quantity(f"{prefix}required_separation_margin_pct", "%", "SM_req", "separation margin required for "
                     "that AF", source=API_SM, headline=headline),
            Quantity(f"{prefix}response_peak_speed_rad_s", "rad/s", "N_c", "speed of the unbalance response's "
                     "peak (the critical speed)", source=API_AF),
            Quantity(f"{prefix}half_power_speeds_rad_s", "rad/s", "N_1, N_2", "half-power points (0.707 of the "
                     "peak) of the unbalance response", source=API_AF))


def margin_words(check: dict) -> str:
    """The check in words for a summary, a verdict or a report: 'AF 24.96, SM 39.98 % from the operating speed
    (API 684 requires 16 %): kept'."""
    af, why = check["amplification_factor"], check.get("amplification_factor_status")
    words = f"AF {f'{af:.4g}' if af is not None else f'not defined ({why})' if why else 'not defined'}"
    if check["separation_margin_pct"] is None:
        return words + " (no operating speed: no separation margin)"
    kept = "kept" if check["separation_margin_ok"] else "NOT kept"
    return (words + f", separation margin {check['separation_margin_pct']:.4g} % from the operating speed (API 684 "
            f"requires {check['required_separation_margin_pct']:.3g} %): {kept}")


# ---- ISO 21940-11 (2016): balance quality grades ------------------------------------------------------------------

def balance_grade(eccentricity: float, speed: float) -> float:
    """G = e_per Omega (ISO 21940-11 (2016), balance quality grade), m/s (G 2.5 is 2.5 mm/s).

    Parameters
    ----------
    eccentricity : float
        e_per, the permissible specific unbalance (eccentricity of the mass centre), m.
    speed : float
        Omega, the maximum service speed, rad/s.
    """
    return eccentricity * speed


def permissible_eccentricity(grade: float, speed: float) -> float:
    """e_per = G/Omega (ISO 21940-11 (2016), permissible specific unbalance of a grade), m.

    Parameters
    ----------
    grade : float
        G, m/s (G 2.5: 2.5e-3 m/s).
    speed : float
        Omega, the maximum service speed, rad/s.
    """
    if not speed > 0:
        raise ValueError(f"the service speed must be positive: {speed:g} rad/s")
    return grade / speed


def permissible_unbalance(grade: float, speed: float, mass: float) -> float:
    """U_per = e_per m = G m/Omega (ISO 21940-11 (2016), permissible residual unbalance), kg m.

    Parameters
    ----------
    grade : float
        G, m/s.
    speed : float
        Omega, rad/s.
    mass : float
        m, the rotor's mass, kg.
    """
    return permissible_eccentricity(grade, speed) * mass
