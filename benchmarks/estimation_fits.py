"""Benchmark: 200 least-squares fits of synthetic rig data, IPOPT (autobal) against
scipy.optimize.least_squares, in one run.

Data: the static characteristic (4.18) with alpha = 1.72, tau_max = 2.75 at 12 loads on [0.5, 2.0]
(the spec's synthetic rig, §5.8) with 2.5 % relative Gaussian noise (Table 4.2's random error of the
static characteristic), a new draw per fit; both parameters free, residual in u.  autobal builds its
NLP once (data are NLP parameters) and calls it 200 times; scipy's trust-region reflective method
gets the same residual and an analytic Jacobian in numpy.  Both start from the source's design
values (1.75, 2.75) with the same bounds.  Run: ``python -m benchmarks.estimation_fits``; writes
benchmarks/results/estimation_fits.md.
"""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np

from autobal.analysis import estimation as est
from benchmarks._timing import best_of

FITS, POINTS, NOISE = 200, 12, 0.025
TAU = np.linspace(0.5, 2.0, POINTS)
START = {"alpha": 1.75, "tau_max": 2.75}


def datasets(seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    u = est.gap_from_load(TAU, 1.72, 2.75)
    return [u * (1 + NOISE * rng.standard_normal(POINTS)) for _ in range(FITS)]



def main(repeats: int = 3) -> str:
    data = datasets()
    t_build = time.perf_counter()
    fitters = {h: est.DiscFitter(POINTS, "u", hessian=h) for h in ("gauss-newton", "exact")}
    t_build = (time.perf_counter() - t_build) / 2

    def raw(fitter):
        """IPOPT solves only (what least_squares does): the built NLP called once per data set."""
        lb = [1e-8 / START["alpha"], TAU.max() * (1 + 1e-9) / START["tau_max"]]
        fixed = [START["alpha"], START["tau_max"], START["alpha"], START["tau_max"]]
        out = []
        for u in data:
            p = np.concatenate([TAU, u, np.zeros(POINTS), [1.0, 1.0], fixed])
            r = fitter.ls.solve([1.0, 1.0], lb, [np.inf, np.inf], p)
            out.append((r["x"] * [START["alpha"], START["tau_max"]], r["iterations"], r["success"]))
        return out

    def full(fitter):
        """DiscFitter.fit: solve plus standard errors, intervals, correlation (a full FitResult)."""
        return [fitter.fit(TAU, u, values=START) for u in data]

    def scipy():
        return [est.scipy_disc_fit(TAU, u, values=START) for u in data]

    rows = {}
    for h, fitter in fitters.items():
        t, out = best_of(repeats, lambda f=fitter: raw(f))
        rows[f"autobal IPOPT, {h} Hessian (solve only)"] = (t, np.array([o[0] for o in out]),
                                                            np.mean([o[1] for o in out]), all(o[2] for o in out))
    t, out = best_of(repeats, lambda: full(fitters["gauss-newton"]))
    rows["autobal DiscFitter.fit, Gauss-Newton (solve + uncertainty)"] = (
        t, np.array([[f.estimate["alpha"], f.estimate["tau_max"]] for f in out]),
        np.mean([f.solver["iterations"] for f in out]), all(f.solver["success"] for f in out))
    t, out = best_of(repeats, scipy)
    ref = np.array([[o["estimate"]["alpha"], o["estimate"]["tau_max"]] for o in out])
    rows["scipy least_squares (trf, analytic Jacobian)"] = (t, ref, np.mean([o["nfev"] for o in out]),
                                                           all(o["success"] for o in out))
    t_peer = rows["scipy least_squares (trf, analytic Jacobian)"][0]
    spread = ref.std(axis=0)
    lines = [
        "# Estimation: 200 fits, autobal IPOPT vs scipy.optimize.least_squares",
        "",
        f"Synthetic rig (spec §5.8): u from (4.18), alpha = 1.72, tau_max = 2.75, {POINTS} loads on [0.5, 2.0], "
        f"{100 * NOISE:.1f} % relative noise, {FITS} data sets; both parameters free, residual in u; best of "
        f"{repeats}.  NLP built once ({t_build * 1e3:.0f} ms per Hessian variant, not timed below).",
        f"Machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}.",
        "",
        "| method | time for 200 fits (s) | per fit (ms) | scipy time / this time | mean iterations (scipy: "
        "residual evaluations) | max abs difference to scipy (alpha, tau_max) | all converged |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, (t, x, it, ok) in rows.items():
        d = np.abs(x - ref).max(axis=0)
        lines.append(f"| {name} | {t:.3f} | {1e3 * t / FITS:.2f} | {t_peer / t:.2f} | {it:.1f} | "
                     f"{d[0]:.1e}, {d[1]:.1e} | {ok} |")
    lines += ["", f"Spread of the 200 estimates (std): alpha {spread[0]:.3f}, tau_max {spread[1]:.3f} "
                  f"(mean {ref[:, 0].mean():.4f}, {ref[:, 1].mean():.4f})."]
    text = "\n".join(lines) + "\n"
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    (out / "estimation_fits.md").write_text(text)
    return text


if __name__ == "__main__":
    print(main())
