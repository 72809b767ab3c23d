"""Scene part ``executor``: where sweeps and Monte Carlo run (in-process, or on a dask.distributed scheduler).
The section is read as it is by :func:`autobal.analysis.executor.make` (no SI parameter object)."""

from __future__ import annotations

from pydantic import Field

from autobal.schema import Strict


class Executor(Strict):
    """Where studies run: in-process (default) or on a dask.distributed scheduler."""

    scheduler: str | None = Field(None, description="e.g. \"tcp://127.0.0.1:8786\"; the CLI's --scheduler overrides it")
    progress: bool = Field(True, description="a progress bar on runs of more than one task (on a terminal)")


SCHEMA = Executor
DESCRIPTION = "where sweeps and Monte Carlo run"
