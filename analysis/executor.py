"""Where sweeps and Monte Carlo studies run: in this process (default) or on a dask.distributed cluster.

A study cuts its work into tasks that depend only on their own index (the Monte Carlo draws each
chunk's samples from ``SeedSequence(seed, spawn_key=(chunk,))``), so the same study gives
identical numbers whichever executor runs it and however many workers the cluster has.  A task is
a picklable callable (plain data; CasADi Functions are rebuilt and cached on the worker).

Choice of executor, first given wins: the CLI's ``--scheduler ADDRESS`` (:func:`set_default_scheduler`),
the scene's ``executor: {scheduler: ADDRESS}``, else in-process.  A progress bar
(analysis/progress.py: on a terminal, not when quiet) follows runs of more than one task.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from autobal.analysis import progress
from autobal.errors import ScenarioError

_DEFAULT_SCHEDULER: str | None = None


def set_default_scheduler(address: str | None) -> None:
    """The scheduler every study uses unless given one explicitly (the CLI's ``--scheduler``)."""
    global _DEFAULT_SCHEDULER
    _DEFAULT_SCHEDULER = address or None


def default_scheduler() -> str | None:
    return _DEFAULT_SCHEDULER


def _bar(total: int, desc: str, show: bool):
    return progress.steps(total, desc, "task", show=show and total > 1)


class InProcess:
    """Runs the tasks one after another in this process."""

    name = "in-process"

    def __init__(self, progress: bool = True):
        self.progress = progress

    def map(self, fn: Callable, items: Sequence, desc: str = "") -> list:
        out = []
        with _bar(len(items), desc, self.progress) as bar:
            for item in items:
                out.append(fn(item))
                bar.tick()
        return out

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class DaskCluster:
    """Runs the tasks on a dask.distributed scheduler at ``address`` (or an existing ``client``);
    results come back in task order."""

    def __init__(self, address: str | None = None, progress: bool = True, client=None, timeout: str = "10s"):
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - dask is a dependency
            raise ScenarioError("executor: dask.distributed is not installed (pip install 'dask[distributed]')") \
                from None
        self.progress = progress
        self._own = client is None
        if client is None:
            try:
                client = Client(address, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise ScenarioError(f"executor.scheduler: cannot reach the dask scheduler at {address!r}: "
                                    f"{exc}") from None
        self.client = client
        self.name = f"dask {self.client.scheduler.address}"

    def map(self, fn: Callable, items: Sequence, desc: str = "") -> list:
        from distributed import as_completed

        futures = self.client.map(fn, list(items), pure=False)
        with _bar(len(futures), desc, self.progress) as bar:
            for _ in as_completed(futures):
                bar.tick()
        return self.client.gather(futures)

    def close(self) -> None:
        if self._own:
            self.client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def make(scheduler: str | None = None, scene_executor=None, progress: bool | None = None):
    """The executor for a study: ``scheduler``, else the CLI default, else the scene's
    ``executor`` block, else in-process."""
    address = scheduler or _DEFAULT_SCHEDULER or getattr(scene_executor, "scheduler", None)
    if progress is None:
        progress = getattr(scene_executor, "progress", True)
    return DaskCluster(address, progress) if address else InProcess(progress)
