"""The coarse screening of the spin-up starts on several threads (ocp/solve.py ``screen``): the same optimum, bit for
bit, as one solve after another, and the study's wall time split still adds up (tests/test_spinup.py)."""

import json
from pathlib import Path

import numpy as np
import yaml

import autobal
from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import solve
from autobal.ocp.spinup_study import method_of

SCENE = json.loads((Path(__file__).parent / "data" / "spinup_family.json").read_text())["problems"]["damped_tight"]


def test_screening_on_two_threads_is_the_screening_one_after_another(tmp_path):
    path = tmp_path / "damped_tight.yaml"
    path.write_text(yaml.safe_dump({"name": "damped_tight", "title": "t"} | SCENE["scene"], sort_keys=False))
    scene = api.load(path)
    ocp, method = spinup_ocp(scene, scene.analyses.spinup), method_of(scene.analyses.spinup)
    runs = {}
    for threads in (1, 2):
        with autobal.using_solver_defaults("spinup_coarse", threads=threads):
            assert solve.screen_threads(7) == min(threads, solve.screen_threads(99))
            runs[threads] = solve.optimize(ocp, method)
    one, two = runs[1], runs[2]
    coarse = [r for r in one.starts if "coarse (" in r.get("stage", "")]
    assert len(coarse) >= 4  # a screening of several starts
    assert np.array_equal(one.solution.w, two.solution.w) and one.score == two.score
    keys = ("start", "stage", "status", "iterations", "objective")
    assert [{k: r.get(k) for k in keys} for r in one.starts] == [{k: r.get(k) for k in keys} for r in two.starts]
    assert one.times["screening"] > 0 and two.times["screening"] > 0
