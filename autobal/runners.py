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

from autobal.analysis.result import Result


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
    from autobal.models.device import design

    return statics_study.run(StaticsSolver(design(scene.device)), settings, scene.title)


def montecarlo(scene, settings) -> Result:
    """Monte Carlo of the device statics (and optionally the AFC) over uncertain groups, on the
    executor the CLI or the scene names."""
    from autobal.analysis import executor
    from autobal.analysis import montecarlo as mc
    from autobal.errors import ScenarioError
    from autobal.models.device import design

    if scene.device is None:
        raise ScenarioError("analyses.montecarlo needs a device section")
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe:
        return mc.run(design(scene.device), settings, exe, scene.title, device=scene.device)


RUNNERS = {
    "statics": statics,
    "frequency": _legacy("frequency", "autobal.analysis.frequency:run"),
    "stability": _legacy("stability", "autobal.analysis.stability:run"),
    "transient": _legacy("transient", "autobal.analysis.simulate:run"),
    "liquid_balancer": _legacy("liquid_balancer", "autobal.analysis.liquid_balancer:run_scenario"),
    "estimation": _legacy("estimation", "autobal.analysis.estimation_study:run"),
    "reliability": _legacy("reliability", "autobal.analysis.reliability:run_scene"),
    "montecarlo": montecarlo,
    "rotor_dynamics": _legacy("rotor_dynamics", "autobal.analysis.rotor_study:run_scene"),
    "spinup": _legacy("spinup", "autobal.ocp.spinup_study:run_scene"),
}


def resolve(target: str):
    """The function named by ``"module:function"``, imported now."""
    module, func = target.split(":")
    return getattr(importlib.import_module(module), func)
