"""Fisher adequacy test of a fitted characteristic on groups of repeated measurements,
Pavlenko (2014), Sec. 4.3.3, Eqs. (4.14)-(4.15), beside the standard lack-of-fit F test, and the one
decision over both (:func:`decision`)."""

from __future__ import annotations

import numpy as np
from scipy import stats

from autobal.analysis.run.quantities import significant

#: the tests of a fit's adequacy: key of its block (``""``: the top level) -> its name in a verdict
TESTS = {"": "Fisher's test (4.14)", "lack_of_fit": "the lack-of-fit test"}


def decision(ad: dict) -> tuple[bool | None, str]:
    """The one adequacy decision of a fit or a curve from its :func:`fisher_adequacy` block (or that block read
    back from results.json): adequate only when every test that could run passes at the block's significance;
    otherwise the words name each test that fails with its F against F_crit and its p against the significance.
    (None, why) when no test ran."""
    if ad.get("F") is None:
        return None, f"adequacy not tested ({ad.get('note', 'no groups of repeated measurements')})"
    level = f"significance {ad.get('significance'):g}"
    fails, passes = [], []
    for key, name in TESTS.items():
        t = ad.get(key) if key else ad
        if not t or t.get("F") is None:
            continue
        F, crit, p = (significant(t.get(k)) for k in ("F", "F_crit", "p_value"))
        if t["F"] <= t["F_crit"]:
            passes.append(f"{name} passes, F = {F} ≤ F_crit = {crit} (p = {p} ≥ {level})")
        else:
            fails.append(f"{name} fails, F = {F} > F_crit = {crit} (p = {p} < {level})")
    if "lack_of_fit" not in ad:
        passes.append("no lack-of-fit test (no repeated measurements in a group)")
    if fails:
        return False, "NOT adequate: " + "; ".join(fails + passes)
    return True, "adequate: " + "; ".join(passes)


def fisher_adequacy(load, measured, group, theory, parameters: int, significance: float = 0.1) -> dict:
    """The source's adequacy test (4.14)-(4.15) and the standard lack-of-fit F test.

    ``theory(loads)`` gives the model value at each group's load.  Source:
    sigma1^2 = sum_groups (u_theory - u_mean)^2/(n - l), sigma2^2 = sum_points (u - u_mean)^2/(m - 1),
    F = sigma1^2/sigma2^2 against F_crit = F_{1-significance}(n - l, m - 1).  **Decision rule: the
    model is adequate when F <= F_crit**; the source's text calls F > F_crit adequate (inverted),
    reported as ``source_rule_adequate``.  The standard test weights each group by its
    size and uses the pure-error variance on m - n degrees of freedom.

    Parameters
    ----------
    load, measured, group : array (m,)
        Load of each point, its measured value and its group label (same units as the model).
    theory : callable
        Model value at each group's mean load.
    parameters : int
        l, the number of fitted parameters.
    significance : float
        Level of the test (1).

    Returns
    -------
    dict: groups, points, group means and theory values, sigma1_sq, sigma2_sq, F, F_crit, dof,
    p_value, fisher_adequate (the test (4.14) alone), source_rule_adequate, lack_of_fit (F, F_crit, dof,
    p_value, adequate) when the groups hold repeats, and the decision over both: ``adequate`` (every test
    passes) and ``decision`` (its words, :func:`decision`).
    """
    load, measured, group = (np.asarray(a, float) for a in (load, measured, group))
    labels = np.unique(group)
    n, m, l_ = len(labels), len(measured), parameters
    idx = np.searchsorted(labels, group)
    sizes = np.bincount(idx)
    means = np.bincount(idx, measured) / sizes
    loads = np.bincount(idx, load) / sizes
    spread = max(np.ptp(load[idx == k]) for k in range(n))
    th = np.asarray(theory(loads), float)
    out = {"groups": n, "points": m, "parameters": l_, "significance": significance,
           "group_load": loads, "group_mean": means, "group_theory": th, "load_spread_in_groups": spread}
    if n - l_ < 1 or m < 2:
        return out | {"F": None, "note": f"needs more groups ({n}) than parameters ({l_})"}
    s1 = np.sum((th - means) ** 2) / (n - l_)
    ss_pe = np.sum((measured - means[idx]) ** 2)
    s2 = ss_pe / (m - 1)
    f_emp = s1 / s2
    f_crit = stats.f.ppf(1 - significance, n - l_, m - 1)
    out |= {"sigma1_sq": s1, "sigma2_sq": s2, "F": f_emp, "F_crit": f_crit, "dof": [n - l_, m - 1],
            "p_value": stats.f.sf(f_emp, n - l_, m - 1), "fisher_adequate": bool(f_emp <= f_crit),
            "source_rule_adequate": bool(f_emp > f_crit),
            "rule": "adequate when F <= F_crit (the source's text calls F > F_crit adequate: inverted)"}
    if m - n >= 1:
        ss_lof = np.sum(sizes * (means - th) ** 2)
        f_lof = (ss_lof / (n - l_)) / (ss_pe / (m - n))
        crit = stats.f.ppf(1 - significance, n - l_, m - n)
        out["lack_of_fit"] = {"F": f_lof, "F_crit": crit, "dof": [n - l_, m - n],
                              "p_value": stats.f.sf(f_lof, n - l_, m - n), "adequate": bool(f_lof <= crit)}
    ok, words = decision(out)
    return out | {"adequate": ok, "decision": words}
