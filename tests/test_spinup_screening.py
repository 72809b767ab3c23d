"""The spin-up study shared with a forked process (analysis/run/forked.py: the global search's back-off searches, the
coarse screening of the starts, the ramp baselines): the same optimum, bit for bit, as everything in one process."""

import json
import os
from pathlib import Path

import numpy as np
import yaml

import autobal
from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.analysis.run import forked
from autobal.ocp import solve
from autobal.ocp.spinup_study import method_of

SCENE = json.loads((Path(__file__).parent / "data" / "spinup_family.json").read_text())["problems"]["damped_tight"]


def test_the_study_shared_with_a_forked_process_is_the_study_in_one_process(tmp_path):
    path = tmp_path / "damped_tight.yaml"
    path.write_text(yaml.safe_dump({"name": "damped_tight", "title": "t"} | SCENE["scene"], sort_keys=False))
    scene = api.load(path)
    ocp, method = spinup_ocp(scene, scene.analyses.spinup), method_of(scene.analyses.spinup)
    runs = {}
    for processes in (1, 2):
        with autobal.using_solver_defaults("parallel", processes=processes):
            assert forked.processes() == min(processes, len(os.sched_getaffinity(0)))
            runs[processes] = solve.optimize(ocp, method)
    one, two = runs[1], runs[2]
    coarse = [r for r in one.starts if "coarse (" in r.get("stage", "")]
    assert len(coarse) >= 4  # a screening of several starts
    assert np.array_equal(one.solution.w, two.solution.w) and one.score == two.score
    keys = ("start", "stage", "status", "iterations", "objective")
    assert [{k: r.get(k) for k in keys} for r in one.starts] == [{k: r.get(k) for k in keys} for r in two.starts]
    assert one.times["screening"] > 0 and two.times["screening"] > 0
