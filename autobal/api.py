"""The Python API: ``load`` a scene, ``run`` its analyses, get Result objects.

>>> import autobal
>>> scene = autobal.load("pump_pe600_statics", set={"device.disc.outer_seal.length": "300 mm"})
>>> run = autobal.run(scene)                     # nothing printed, nothing written
>>> run["statics"].face_gap                      # m
>>> run.save("out/pump")                         # results.json, CSV, PNG and SVG; atomically
>>> with autobal.display_units({"pressure": "bar"}):  # what a person reads; results.json stays SI
...     print(run["statics"].summary())
"""

from __future__ import annotations

import contextlib
import datetime
import platform
import sys
import time
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path

from threadpoolctl import threadpool_limits

from autobal import __version__, analyses, report, scenario
from autobal.analysis.run import executor, interrupt
from autobal.analysis.run.quantities import display_units
from autobal.analysis.run.result import Result, html_figure, write_json
from autobal.errors import AutobalError, SolveError
from autobal.output import LOG, OutputFolder, SolverLog, signals_held
from autobal.scenario import BaseScenario as Scenario  # every scene model (see scenario.model_for)

NO_ACCURACY = {"estimate": None, "how": "this analysis reports no error estimate"}


def load(name_or_path: str | Path, set: dict | None = None) -> Scenario:  # noqa: A002 (the documented name)
    """Read and validate a scene.

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario (``autobal list``).
    set : dict, optional
        Overrides: dotted scene paths -> values with units, as they would be written in the YAML
        (``{"device.disc.outer_seal.length": "300 mm"}``; pint quantities are accepted too). They are
        validated exactly like the file.

    Returns
    -------
    Scenario
        The validated scene, every quantity in SI.

    Raises
    ------
    ScenarioError
        One line naming the file or override, the field and the expected unit.
    """
    return scenario.load(name_or_path, overrides=set)


class Run(Mapping):
    """The results of one run of a scene: analysis name -> :class:`~autobal.analysis.run.result.Result`.

    ``timing`` holds the wall time of each analysis, s; ``meta`` the version, time, platform and the
    resolved scene.
    """

    def __init__(self, scene: Scenario, results: dict[str, Result], timing: dict[str, float]):
        self.scene, self.results, self.timing = scene, results, timing
        self.meta = meta(scene)

    def __getitem__(self, name: str) -> Result:
        return self.results[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.results)

    def __len__(self) -> int:
        return len(self.results)

    @property
    def failures(self) -> dict[str, list[str]]:
        """Analysis name -> what failed inside it (:meth:`Result.failures`), for the analyses with failures."""
        return {name: f for name, r in self.results.items() if (f := r.failures())}

    @property
    def status(self) -> str:
        """The run's status: "ok" when every analysis solved what it reports, else "failed" (results kept)."""
        return "failed" if self.failures else "ok"

    def to_dict(self) -> dict:
        """The content of results.json (without the ``files`` list, which ``save`` adds)."""
        s = self.scene
        out = {"status": self.status, "failures": self.failures, "scenario": s.name, "title": s.title,
               "source": s.source, "meta": self.meta,
               "timing": self.timing, "accuracy": {}}
        for name, res in self.results.items():
            block = res.to_dict()
            out["accuracy"][name] = block.get("accuracy", NO_ACCURACY)
            out[name] = block
        out["units"] = report.units(out, list(self.results))
        return out

    def summary(self) -> str:
        """Every result's summary, in the display units of the scene (its ``display`` section)."""
        with display_units(display(self.scene), under=True):
            return "\n".join(r.summary() for r in self.results.values())

    def write(self, folder: Path) -> list[Path]:
        """Write every result's files (tables and figures in the display units of the scene), results.json (SI)
        and report.html into an existing ``folder``."""
        outputs, captions = {}, {}
        with display_units(display(self.scene), under=True):
            for name, r in self.results.items():
                paths, words = r.write(folder)
                outputs[name], captions = [p.name for p in paths], captions | words
        files = [name for names in outputs.values() for name in names]
        write_json(folder / "results.json", self.to_dict() | {"files": [*files, report.REPORT], "outputs": outputs,
                                                              "captions": captions})
        written = _render_report(folder)
        if not written:
            warnings.warn("report.html not written (see autobal.log)", stacklevel=2)
        return [folder / f for f in files] + written

    def save(self, out: str | Path) -> Path:
        """Write the run into ``out`` atomically (see :mod:`autobal.output`); returns the folder."""
        folder = OutputFolder(out)
        with folder as tmp:
            self.write(tmp)
        return folder.path

    def tables(self) -> dict[str, dict]:
        """Every result's CSV tables: file name -> {column: values}."""
        return {name: cols for r in self.results.values() for name, cols in r.tables().items()}

    def to_dataframe(self, table: str | None = None):
        """The tables as pandas DataFrames (pandas is optional): one by file name, or a dict of all."""
        frames = {name: df for r in self.results.values() for name, df in r.to_dataframe().items()}
        if table is None:
            return frames
        if table not in frames:
            raise KeyError(f"the run has no table {table!r}; it has: {', '.join(frames) or 'none'}")
        return frames[table]

    def _repr_html_(self, figures: bool = True) -> str:
        """Jupyter's view: per analysis the one verdict, the headline table in display units and the figures."""
        imgs = {name: [html_figure(f.figure) for f in r.figures().values()] if figures else []
                for name, r in self.results.items()}
        return report.notebook(self.to_dict(), imgs)

    def __repr__(self) -> str:
        return f"<Run {self.scene.name}: {', '.join(self.results)}>"


def display(scene: Scenario) -> dict[str, str]:
    """The display units the scene chooses (its ``display`` section): kind -> unit."""
    return scene.display.model_dump(exclude_none=True) if scene.display is not None else {}


def meta(scene: Scenario) -> dict:
    """Provenance of a run: versions, time, platform, the scene file's hash and the scene in SI."""
    return {"autobal_version": __version__,
            "timestamp": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "python": sys.version.split()[0], "platform": platform.platform(),
            **scene._origin, "scene_si": scene.model_dump(mode="json", exclude_none=True)}


def _finish(folder: OutputFolder, scene: Scenario, name: str, data: dict) -> None:
    """Write a status file (with the scene and the run's provenance) and its report.html into the
    temporary folder, and commit it; a second interrupt meanwhile is raised when that is done."""
    with signals_held():
        write_json(folder.tmp / name, data | {"scenario": scene.name, "title": scene.title, "meta": meta(scene)})
        _render_report(folder.tmp)
        folder.commit()


def _render_report(folder: Path) -> list[Path]:
    """report.html of ``folder`` ([] when it cannot be rendered: the results or the run's own error matter
    more than the page; why goes to autobal.log)."""
    try:
        return [report.render(folder)]
    except Exception as exc:  # noqa: BLE001 (a report must not lose the results or replace the run's error)
        _note(folder, f"report.html not written: {type(exc).__name__}: {exc}")
        return []


def _note(folder: Path, line: str) -> None:
    """Append one line to ``folder``'s autobal.log."""
    with open(folder / LOG, "a") as log:
        log.write(line + "\n")


def run(scene: Scenario | str | Path, out: str | Path | None = None, on_result=None,
        scheduler: str | None = None) -> Run:
    """Run every analysis the scene names.

    Parameters
    ----------
    scene : Scenario, str or Path
        A scene from :func:`load`, or what :func:`load` takes.
    out : str or Path, optional
        Output folder. When given, the run is written there atomically: results.json, CSV tables,
        PNG figures and ``autobal.log`` (each IPOPT solve's iterations and status, each analysis' status; nothing
        of the process is redirected, so runs in several threads keep their own logs); a failed solve leaves
        ``failed_solve.json`` instead and an interrupt ``interrupted.json`` (see :mod:`autobal.output`).
        Nothing is written when omitted.
    on_result : callable, optional
        Called as ``on_result(name, result, seconds)`` after each analysis (the CLI prints with it).
    scheduler : str, optional
        Run sweeps and Monte Carlo on the dask.distributed scheduler at this address (default: the
        environment variable ``AUTOBAL_SCHEDULER``, else in this process).  A scene cannot name one: a
        scheduler's results are unpickled here, so it is trusted like code.

    The run's dense linear algebra (numpy, scipy, ROSS) uses one BLAS thread: a multithreaded BLAS sums in an order
    that changes from run to run, and the ROSS rotors' eigenvectors, then the spin-up optimum chosen from them,
    changed with it (at 1e-8, and by 1 % in the robust ROSS scene); with one thread a scene gives the same numbers
    on every run.  The solvers' own threads (IPOPT's MUMPS, CVODES) are not affected.

    Returns
    -------
    Run
        Analysis name -> Result, each with the display units of the scene (``Result.display_choice``: its
        ``summary()``, tables and figures show them wherever they are called).  ``run.status`` is "failed" when an
        analysis finished with failures (``run.failures``: a residual above its tolerance, an integrator failure);
        the results are kept.

    Raises
    ------
    SolveError
        A solver did not converge: its status and last iterate are on the exception.
    ScenarioError
        The scene cannot be run as given.
    """
    if not isinstance(scene, Scenario):
        scene = load(scene)
    interrupt.clear()  # an interrupt of an earlier run in this process is not this run's
    interrupt.ensure()  # record SIGINT/SIGTERM even when they arrive inside a solver
    folder = OutputFolder(out) if out is not None else None
    results, timing, current = {}, {}, None
    log = SolverLog(folder.tmp / LOG) if folder is not None else None
    try:
        with log or contextlib.nullcontext(), executor.using(scheduler), threadpool_limits(1, user_api="blas"), \
                display_units(display(scene), under=True):  # the summaries on_result prints
            for current in analyses.named(scene):
                t0 = time.perf_counter()
                try:
                    results[current] = analyses.module(current).run(scene, getattr(scene.analyses, current))
                finally:
                    interrupt.check()  # an interrupt a solver swallowed, or turned into another error, is one
                timing[current] = time.perf_counter() - t0
                results[current].display_choice = display(scene)  # its summary() later shows what the run did
                failures = results[current].failures()
                if log is not None:
                    log.write(f"=== {current}: {'failed: ' + '; '.join(failures) if failures else 'ok'} "
                              f"({timing[current]:.2f} s)")
                if on_result is not None:
                    on_result(current, results[current], timing[current])
        done = Run(scene, results, timing)
        if folder is not None:
            done.write(folder.tmp)
            folder.commit()
        return done
    except SolveError as exc:
        if folder is not None:
            _note(folder.tmp, f"=== {current}: solve failed, status {exc.status}: {exc}")
            _finish(folder, scene, "failed_solve.json", {"status": exc.status, "analysis": current,
                                                         "error": str(exc), "last_iterate": exc.last_iterate})
        raise
    except KeyboardInterrupt:
        if folder is not None:
            _finish(folder, scene, "interrupted.json", {"status": "interrupted", "analysis": current,
                                                        "completed": list(results)})
        raise
    except AutobalError as exc:
        if folder is not None:
            _note(folder.tmp, f"=== {current}: {type(exc).__name__}: {exc}")
            _finish(folder, scene, "error.json", {"status": "error", "analysis": current, "error": str(exc)})
        raise
    except BaseException:
        if folder is not None:
            folder.discard()
        raise



class LoadedRun(Mapping):
    """A finished run loaded back from its output folder (:func:`load_run`): analysis name -> Result.

    ``results`` holds the loaded Results (as :attr:`Run.results`), ``saved`` results.json as read; ``unloaded``
    names the analyses whose Result cannot be rebuilt from its block (analysis -> why: a Result that holds more
    than its block), which are then only in ``saved``.
    """

    def __init__(self, folder: Path, saved: dict, results: dict[str, Result], unloaded: dict[str, str]):
        self.folder, self.saved, self.results, self.unloaded = folder, saved, results, unloaded

    __getitem__, __iter__, __len__ = Run.__getitem__, Run.__iter__, Run.__len__  # name -> Result, as a Run

    @property
    def failures(self) -> dict[str, list[str]]:
        """Analysis name -> what failed inside it, as results.json records it."""
        return dict(self.saved.get("failures") or {})

    @property
    def status(self) -> str:
        """The run's status as results.json records it ("ok" or "failed")."""
        return self.saved.get("status", "")

    def __repr__(self) -> str:
        return f"<LoadedRun {self.saved.get('scenario', '')}: {', '.join(self.results)}>"


def load_run(folder: str | Path) -> LoadedRun:
    """Load a finished run back from its output folder into Result objects.

    Parameters
    ----------
    folder : str or Path
        An output folder of ``autobal run`` (or :meth:`Run.save`) holding results.json.

    Returns
    -------
    LoadedRun
        Analysis name -> Result: a typed Result rebuilt by ``from_dict`` (``to_dict()`` gives its block of
        results.json back), a Result holding only ``data`` with its block; ``unloaded`` says which could not be.

    Raises
    ------
    ScenarioError
        The folder holds no readable results.json.
    """
    from autobal import report_input
    from autobal.errors import ScenarioError

    where = report_input.folder_of(folder)
    if not report_input.present(where, "results.json"):
        raise ScenarioError(f"{where}: holds no results.json (not a finished run)")
    saved = report_input.read_json(where / "results.json")
    results, unloaded = {}, {}
    for name in (k for k in saved if k in report.SECTIONS):
        try:
            results[name] = report.load_result(name, saved[name], where)
        except (ValueError, KeyError, TypeError) as exc:
            unloaded[name] = str(exc)
    return LoadedRun(where, saved, results, unloaded)
