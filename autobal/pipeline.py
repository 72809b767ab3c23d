"""The analyses a scene can name, each a runner: (scenario, its settings, output folder) ->
(results.json block, files written, printed summary).  ``RUNNERS`` order is the run order."""

from __future__ import annotations

import time
from pathlib import Path


def statics(scn, settings, out: Path):
    """Static calculation of the balancing device (analysis/statics_study.py)."""
    from autobal.analysis import statics_study
    from autobal.analysis.statics import StaticsSolver
    from autobal.models.device import design

    t0 = time.perf_counter()
    res = statics_study.run(StaticsSolver(design(scn.device)), settings, scn.title)
    files = res.write_tables(out) + res.plot(out)
    return res.to_dict() | {"run_time_s": time.perf_counter() - t0}, files, res.summary()


RUNNERS = {"statics": statics}
