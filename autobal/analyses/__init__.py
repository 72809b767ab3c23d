"""The analyses a scene can name: one module each, ``autobal/analyses/<key>.py``, its room.

An analysis module defines

- ``SETTINGS``: the pydantic schema of ``analyses.<key>`` (a :class:`autobal.schema.Strict` model);
- ``DESCRIPTION``: one line for the schema reference;
- ``NEEDS``: the part of the scene it needs, a dotted path checked at load time (``"device.dynamics"``), or None;
- ``run(scene, settings) -> Result``: the validated scene and its settings to the analysis' Result (it writes
  no files and prints nothing; the scene's parts become SI parameter objects through :mod:`autobal.parts`);
- ``estimate_seconds(settings) -> float``: its predicted run time, from the per-unit costs :data:`COST`;
- ``QUANTITIES_MODULE``: the module whose ``QUANTITIES`` declare every number of its results block;
- ``TITLE``: the title of its section of report.html;
- ``report_section(sec)``: its section of report.html, drawn from its results block into the
  :class:`autobal.report.Section` ``sec`` (it imports what it needs from :mod:`autobal.report` inside);
- optionally ``accuracy(scene, settings)``: its work-precision study (``autobal accuracy``).

:data:`MODULES` is the one list kept by hand: one line per analysis, in the scene's order, which is also the
run order.  Everything else is read from the modules, which are imported on first use only (a statics scene
imports no dynamics).  docs/contributing.md says how to add an analysis.
"""

from __future__ import annotations

import importlib
from types import ModuleType

MODULES = {
    "statics": "autobal.analyses.statics",
    "frequency": "autobal.analyses.frequency",
    "stability": "autobal.analyses.stability",
    "transient": "autobal.analyses.transient",
    "liquid_balancer": "autobal.analyses.liquid_balancer",
    "estimation": "autobal.analyses.estimation",
    "montecarlo": "autobal.analyses.montecarlo",
    "reliability": "autobal.analyses.reliability",
    "rotor_dynamics": "autobal.analyses.rotor_dynamics",
    "spinup": "autobal.analyses.spinup",
    "spinup_robust": "autobal.analyses.spinup_robust",
    "spinup_time_optimal": "autobal.analyses.spinup_time_optimal",
    "design": "autobal.analyses.design",
    "ross_spinup": "autobal.analyses.ross_spinup",
    "ross_spinup_robust": "autobal.analyses.ross_spinup_robust",
    "ross_spinup_time_optimal": "autobal.analyses.ross_spinup_time_optimal",
    "runup": "autobal.analyses.runup",
}


def module(key: str) -> ModuleType:
    """The module of analysis ``key`` (imported now if it was not)."""
    return importlib.import_module(MODULES[key])


def named(scene) -> list[str]:
    """The analyses a validated scene names, in run order."""
    return [key for key in MODULES if getattr(scene.analyses, key, None) is not None]


#: optional extras: name -> (the module it installs, how to install it); an analysis module that needs one names it
#: in ``EXTRA``
EXTRAS = {"ross": ("ross", "pip install 'autobal[ross]'")}


def extras(scene) -> dict[str, bool]:
    """The extras the analyses of a validated scene need -> whether each is installed (nothing is imported)."""
    import importlib.util
    import sys

    out = {}
    for key in named(scene):
        extra = getattr(module(key), "EXTRA", None)
        if extra is not None:
            name = EXTRAS[extra][0]
            out[extra] = sys.modules[name] is not None if name in sys.modules else \
                importlib.util.find_spec(name) is not None
    return out


def check(scene) -> list[str]:
    """Pose each analysis' problem as its run would, without solving (``autobal check``): the analyses whose room
    has ``check(scene, settings)`` (the spin-up problems: a drive that cannot reach the final speed by the deadline
    is refused here, as by the run).  A problem that cannot be posed raises ScenarioError; returns the analyses
    posed (an analysis whose extra is missing is not)."""
    missing = {name for name, installed in extras(scene).items() if not installed}
    posed = []
    for key in named(scene):
        mod = module(key)
        if hasattr(mod, "check") and getattr(mod, "EXTRA", None) not in missing:
            mod.check(scene, getattr(scene.analyses, key))
            posed.append(key)
    return posed


def accuracy_studies() -> dict:
    """Analysis -> its work-precision study ``accuracy(scene, settings)``, for the analyses that have one
    (imports every analysis module: for ``autobal accuracy`` only)."""
    return {key: module(key).accuracy for key in MODULES if hasattr(module(key), "accuracy")}


# ---- predicted run time ----------------------------------------------------------------------------------
# Seconds per unit of work on one core of the reference machine (a 2-core x86-64 laptop), calibrated on the
# shipped scenes; an estimate within a factor of about 3, for warning before long runs, not a measurement.
COST = {
    "start": 1.0,  # building the solvers of an analysis
    "ipopt_solve": 4e-3,  # one warm-started IPOPT solve of the device statics (sweep, force-gap point)
    "mc_statics_sample": 1.5e-5,  # one Monte Carlo sample at one discharge ratio (mapped Newton)
    "mc_afc_point": 1.5e-6,  # one Monte Carlo sample at one frequency (linear model)
    "afc_point": 2e-4,  # one frequency of one model's AFC
    "map_point": 3e-3,  # one point of a stability map, per model
    "transient_point": 5e-4,  # one output time of one time response (CVODES)
    "ocp_collocation_point": 5e-3,  # one collocation point of the spin-up OCP, per start
    "robust_validation_run": 4e-3,  # one profile on one validation rotor (exponential integrator)
    "modal_ocp_point": 0.02,  # one collocation point of the multi-mode (ROSS) spin-up OCP, per start
    # ROSS: importing it, compiling its numba code and building the rotor's matrices; its own critical speeds (the
    # shipped spinup_ross_rotor: about 90 s in all, of which these two are about 15 % and 25 % (5.5 s and 10 s of its
    # 39 s of CPU measured on a loaded 2-core machine, the rest the search, the NLP solves and the re-simulations)
    "ross_rotor": 12.0,
    "ross_critical_speeds": 23.0,
    "reliability_node": 5e-7,  # one (time, load) node of the reliability integrals
    "rotor_run": 0.5,  # one CVODES passage / step response of the rotor studies
    "grid_point": 1e-5,  # one point of a dense cross-check grid
    "fit": 2.0,  # one least-squares fit with its cross-checks
    "fit_point": 1e-4,  # one data row of a fit, its cross-check and its results (100,000 rows: 10 s CPU measured)
    "bootstrap_point": 1.5e-6,  # one data row of one bootstrap refit (1000 rows x 2000 samples: 2.7 s CPU)
    # one statics solve with the eigenvalues of the design at one operating point (the shipped design scenes:
    # 32 s and 15 s of CPU for about 1230 and 930 of them, on a loaded machine)
    "design_point": 0.02,
    "runup_vector": 0.05,  # one measured revolution of a run-up identification (its RK4 steps, both fits, figures)
}
LONG_RUN_S = 60.0  # a run predicted to take longer says so first


def estimate_seconds(scene) -> dict[str, float]:
    """Predicted wall time of each analysis of a scene, by each analysis' cost model (``estimate_seconds``
    of its module, from :data:`COST`).

    Parameters
    ----------
    scene : Scenario
        A validated scene.

    Returns
    -------
    dict
        Analysis name -> predicted time, s (single core; an estimate within a factor of about 3).
    """
    return {key: module(key).estimate_seconds(getattr(scene.analyses, key)) for key in named(scene)}


def long_run_note(scene) -> str | None:
    """One line to print before a run predicted to take more than :data:`LONG_RUN_S`, else None.

    Parameters
    ----------
    scene : Scenario
        A validated scene.

    Returns
    -------
    str or None
        E.g. "this run is estimated to take about 7 min (statics 6.8 min, ...)".
    """
    est = estimate_seconds(scene)
    total = sum(est.values())
    if total <= LONG_RUN_S:
        return None

    def fmt(s):
        return f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"

    parts = ", ".join(f"{k} {fmt(v)}" for k, v in sorted(est.items(), key=lambda kv: -kv[1]))
    return f"this run is estimated to take about {fmt(total)} ({parts})"
