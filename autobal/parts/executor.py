"""Scene part ``executor``: how sweeps and Monte Carlo run (the progress bar; where they run is never a scene's
choice). The section is read as it is by :func:`autobal.analysis.run.executor.make` (no SI parameter object)."""

from __future__ import annotations

from pydantic import Field, model_validator

from autobal.schema import Strict


class Executor(Strict):
    """How studies run: the progress bar.  Where they run (a dask.distributed scheduler) is never a scene's
    choice: ``--scheduler``, ``autobal.run(..., scheduler=...)`` or the environment variable AUTOBAL_SCHEDULER."""

    progress: bool = Field(True, description="a progress bar on runs of more than one task (on a terminal)")

    @model_validator(mode="before")
    @classmethod
    def _no_scheduler(cls, data):
        if isinstance(data, dict) and "scheduler" in data:
            raise ValueError("scheduler: a scene cannot name a scheduler (a scene is data and contacts no host); "
                             "give it on the command line (--scheduler), in the API (autobal.run(..., "
                             "scheduler=...)) or in the environment (AUTOBAL_SCHEDULER)")
        return data


SCHEMA = Executor
DESCRIPTION = "how sweeps and Monte Carlo run (the progress bar)"
