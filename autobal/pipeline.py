"""The analyses a scene can name.  Each runner is ``module:function`` with the signature
(scenario, its settings, output folder) -> (results.json block, files written, printed summary),
imported only when a scene names it.  ``RUNNERS`` order is the run order; one line per analysis."""

from __future__ import annotations

import importlib
import time
from pathlib import Path

RUNNERS = {
    "statics": "autobal.pipeline:statics",
    "frequency": "autobal.analysis.frequency:run",  # device dynamics: AFC/Bode (2.100)-(2.110)
    "stability": "autobal.analysis.stability:run",  # poles, Hurwitz, stability maps
    "transient": "autobal.analysis.simulate:run",  # CVODES/IDAS time responses (2.111)
    "liquid_balancer": "autobal.analysis.liquid_balancer:run_scenario",
    "estimation": "autobal.analysis.estimation_study:run",
    "reliability": "autobal.analysis.reliability:run_scene",
    "montecarlo": "autobal.analysis.montecarlo:run_scene",
    "rotor_dynamics": "autobal.analysis.rotor_study:run_scene",  # Pashkov 2010 rotor + liquid ABU studies
    "spinup": "autobal.ocp.spinup_study:run_scene",  # optimal spin-up through the critical speed (OCP)
}


def resolve(target: str):
    """The function named by ``"module:function"``, imported now."""
    module, func = target.split(":")
    return getattr(importlib.import_module(module), func)


def runner(name: str):
    return resolve(RUNNERS[name])


def statics(scn, settings, out: Path):
    """Static calculation of the balancing device (analysis/statics_study.py)."""
    from autobal.analysis import statics_study
    from autobal.analysis.statics import StaticsSolver
    from autobal.models.device import design

    t0 = time.perf_counter()
    res = statics_study.run(StaticsSolver(design(scn.device)), settings, scn.title)
    files = res.write_tables(out) + res.plot(out)
    return res.to_dict() | {"run_time_s": time.perf_counter() - t0}, files, res.summary()
