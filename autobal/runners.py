"""One runner per analysis a scene can name: ``runner(scene, settings) -> Result``.

A runner turns the validated scene into what the analysis takes (parameter objects in SI,
through :mod:`autobal.adapters` where they exist) and returns the analysis' Result; it writes
no files and prints nothing.  ``RUNNERS`` order is the run order.
"""

from __future__ import annotations

import importlib
import shutil
import tempfile
from pathlib import Path

from autobal import adapters
from autobal.analysis.result import Result
from autobal.errors import ScenarioError


class LegacyResult(Result):
    """An analysis not yet converted to the Result protocol: its block, summary and the files its
    old runner wrote (kept in a private temporary folder until saved).  ``plot()`` is not available."""

    def __init__(self, name: str, block: dict, files: list[Path], text: str, keep: tempfile.TemporaryDirectory):
        self.name, self._block, self._files, self._text, self._keep = name, block, files, text, keep

    def to_dict(self) -> dict:
        return self._block

    def summary(self) -> str:
        return self._text

    def plot(self, ax=None):
        raise NotImplementedError(f"the {self.name} result cannot plot yet; its figures are written by save()")

    def save(self, folder) -> list[Path]:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        return [Path(shutil.copy2(f, folder / f.name)) for f in self._files]


def _legacy(name: str, target: str):
    """A runner around an old ``(scene, settings, out) -> (block, files, summary)`` function."""

    def run(scene, settings) -> Result:
        keep = tempfile.TemporaryDirectory(prefix=f"autobal-{name}-")
        block, files, text = resolve(target)(scene, settings, Path(keep.name))
        return LegacyResult(name, block, files, text, keep)

    run.__doc__ = f"Runner of ``analyses.{name}`` (not yet converted: {target})."
    return run


def statics(scene, settings) -> Result:
    """Static calculation of the balancing device: operating point, criticals, sweep, force-gap."""
    from autobal.analysis import statics_study
    from autobal.analysis.statics import StaticsSolver

    return statics_study.run(StaticsSolver(adapters.design(scene.device)), settings, scene.title)


def frequency(scene, settings) -> Result:
    """AFC/PFC of the face gap of every named model (Pavlenko (2014), Eqs. (2.100)-(2.110))."""
    from autobal.analysis import frequency as fr
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    o = settings.omega
    res = fr.study(setup, list(settings.models), settings.forcing, (o.start, o.stop, o.points), scene.title)
    res.data["accuracy"] = fr.accuracy(setup, res.data["curves"], settings.forcing)
    return res


def stability(scene, settings) -> Result:
    """Poles, damping, Hurwitz determinants, margin and the optional stability map."""
    from autobal.analysis import stability as st
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    res = st.study(setup, list(settings.models), settings.map, scene.title)
    res.data["accuracy"] = st.accuracy(setup, list(settings.models))
    return res


def transient(scene, settings) -> Result:
    """Time responses of the nonlinear device model from its static solution (CVODES / IDAS)."""
    from autobal.analysis import simulate as sim
    from autobal.analysis.linearize import Setup

    setup = Setup(adapters.dynamic_device(scene), settings.operating_ratio)
    model = setup.nonlinear("chain" if settings.model == "nonlinear_chain" else "energy")
    cases = [{"input": c.input, "amplitude": c.amplitude, "frequency": c.frequency,
              "couple": c.thrust_follows_pressure} for c in settings.cases]
    res = sim.study(model, cases, settings.duration, settings.points, settings.integrator, scene.title)
    res.data["accuracy"] = sim.accuracy(model, res, cases, settings.duration, settings.points, settings.integrator)
    return res


def liquid_balancer(scene, settings) -> Result:
    """Design calculations of the liquid auto-balancer (Khomyak (2020); Pashkov (2010), ch. 3)."""
    from autobal.analysis import liquid_balancer as lb

    return lb.run(adapters.liquid_balancer(scene.liquid_balancer), settings, scene.title)


def rotor_dynamics(scene, settings) -> Result:
    """The source's studies of the Jeffcott rotor with a liquid auto-balancer (Pashkov (2010))."""
    from autobal.analysis import rotor_study

    if scene.rotor is None:
        raise ScenarioError("analyses.rotor_dynamics needs a rotor section")
    drive = scene.rotor.drive
    return rotor_study.run(adapters.rotor(scene.rotor), settings, scene.title, drive.motor if drive else None)


def montecarlo(scene, settings) -> Result:
    """Monte Carlo of the device statics (and optionally the AFC) over uncertain groups (Pavlenko (2014),
    ch. 3), on the executor the CLI or the scene names."""
    from autobal.analysis import executor
    from autobal.analysis import montecarlo as mc

    if scene.device is None:
        raise ScenarioError("analyses.montecarlo needs a device section")
    device = adapters.device(scene.device)
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe:
        return mc.run(adapters.design(scene.device), settings, exe, scene.title, device=device)


def design(scene, settings) -> Result:
    """Stability-constrained design of the balancing device (analysis/design.py)."""
    from autobal.analysis import design as ds
    from autobal.analysis import design_study

    try:
        bounds = settings.bounds_si()
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    variables = tuple(ds.Variable(path, key, lo, hi) for path, (key, lo, hi) in bounds.items())
    gap = (settings.face_gap.lower, settings.face_gap.upper)
    weights = {"leakage": (1.0, 0.0), "stiffness": (0.0, 1.0), "mix": tuple(settings.weights)}[settings.objective]
    spec = ds.Spec(variables=variables, points=tuple(settings.operating_ratios), nominal_ratio=settings.nominal_ratio,
                   decay_rate=settings.decay_rate, gap=gap, valve_band=settings.valve_band,
                   min_stiffness=-float("inf") if settings.min_stiffness is None else settings.min_stiffness,
                   weights=weights, form=settings.model)
    return design_study.run(adapters.dynamic_device(scene), spec, settings.samples, settings.seed,
                            settings.sweep_points, scene.title)


def reliability(scene, settings) -> Result:
    """Reliability of the traditional balance disc: P(t), MTTF, wear (Pavlenko 2014, ch. 1.2)."""
    from autobal.analysis import reliability as rel

    return rel.run(settings, scene.title)


def estimation(scene, settings) -> Result:
    """Parameter estimation from measured static and flow characteristics (Pavlenko (2014), Sec. 4.4)."""
    from autobal.analysis import estimation_study

    device = adapters.device(scene.device) if scene.device is not None else None
    return estimation_study.run(settings, device, scene.title)


def spinup(scene, settings) -> Result:
    """Optimal spin-up through the critical speed (global search, collocation, CVODES re-simulation)."""
    from autobal.ocp import spinup_study

    return spinup_study.from_scene(scene, settings)


RUNNERS = {
    "statics": statics,
    "frequency": frequency,
    "stability": stability,
    "transient": transient,
    "liquid_balancer": liquid_balancer,
    "estimation": estimation,
    "reliability": reliability,
    "montecarlo": montecarlo,
    "rotor_dynamics": rotor_dynamics,
    "spinup": spinup,
    "design": design,
}


def resolve(target: str):
    """The function named by ``"module:function"``, imported now."""
    module, func = target.split(":")
    return getattr(importlib.import_module(module), func)
