"""Numbers in docs/ that the toolkit computes come from runs (docs/run_numbers.py, docs/numbers.json, the
``{{ n:... }}`` placeholders that docs/hooks.py replaces): every placeholder resolves, an unknown one stops
the build, and (slow) a fresh run of each recorded scene gives the recorded values."""

import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md"))


def _module(name: str):
    spec = importlib.util.spec_from_file_location(f"docs_{name}", ROOT / "docs" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


pytestmark = pytest.mark.extra("docs")
pytest.importorskip("mkdocs")
hooks = _module("hooks")
runner = _module("run_numbers")
RECORDED = json.loads(runner.NUMBERS.read_text(encoding="utf-8"))


def _page(path: Path) -> str:
    """A page as the hook sees it: with its ``<!-- include: -->`` files in."""
    return hooks.INCLUDE.sub(hooks._include, path.read_text(encoding="utf-8"))


def test_every_placeholder_in_docs_resolves():
    used = 0
    for path in PAGES:
        text = _page(path)
        used += len(hooks.NUMBER.findall(text))
        out = hooks.numbers_markdown(text)
        assert not hooks.LEFT.search(out), path
    assert used > 0


def test_the_design_decay_rates_and_the_robust_worst_case_come_from_runs():
    """The first numbers converted (issue 24): the design page's decay rates and the robust worst case."""
    design = (ROOT / "docs" / "design.md").read_text(encoding="utf-8")
    assert "{{ n:pump_pe600_design.decay_rate_1_s" in design
    assert "{{ n:compressor_k180_design.decay_rate_1_s" in design
    robust = _page(ROOT / "docs" / "theory" / "spinup_robust.md")
    assert "{{ n:spinup_robust_jeffcott.robust.validation_worst_over_e" in robust


def test_a_placeholder_is_the_recorded_value_in_its_format():
    runs = {"runs": {"s": {"command": "autobal run s", "commit": "0123456789abcdef", "date": "2026-11-26T09:00",
                           "values": {"a": 337.46, "b": [1.0, -2.345], "c": {"d": 12}, "t": 1.558e-4,
                                      "g": 8.56618e-9}}}}
    text = ("{{ n:s.a:.0f }} / {{n:s.b:.2f}} / {{ n:s.b.1:.1f }} / {{ n:s.c.d }} / {{ n:s.t*1e3:.3f }} ms / "
            "{{ n:s.g:.4e }} / {{ n:s.a*1e3:.3g }} ({{ run:s }})")
    assert hooks.numbers_markdown(text, runs) == (
        "337 / 1.00, −2.35 / −2.3 / 12 / 0.156 ms / 8.5662e-9 / 3.37e5 (`autobal run s` at commit 0123456789 "
        "(2026-11-26))")


def test_every_recorded_run_names_its_command_and_commit():
    assert set(RECORDED["runs"]) == set(runner.EXTRACT)
    for scene, run in RECORDED["runs"].items():
        assert run["command"] == f"autobal run {scene}"
        assert re.fullmatch(r"[0-9a-f]{40}(\+dirty)?", run["commit"]), scene
        assert run["values"]


def test_tolerances_name_recorded_values_and_can_fail():
    for scene, rules in runner.TOLERANCE.items():
        values = RECORDED["runs"][scene]["values"]
        for key in rules:
            node = values
            for part in key.split(".") if key else []:
                node = node[int(part)] if isinstance(node, list) else node[part]
    assert runner.tolerance("pump_pe600_design", "decay_rate_1_s.2") == runner.MANIFOLD
    assert runner.tolerance("pump_pe600_design", "leakage_m3_s.1") == runner.DEFAULT_TOLERANCE
    assert runner.tolerance("spinup_robust_jeffcott", "robust.validation_worst_over_e") == 1e-2
    assert runner.differences("pump_pe600_design", {"decay_rate_1_s": [337.4]}, {"decay_rate_1_s": [323.0]})
    assert not runner.differences("pump_pe600_design", {"decay_rate_1_s": [337.4]}, {"decay_rate_1_s": [336.0]})
    assert runner.differences("spinup_robust_jeffcott", {"robust": {"x": 18.51}}, {"robust": {"x": 18.70}})
    assert runner.differences("pump_pe600_design", {"accuracy_estimate": 1e-11}, {"accuracy_estimate": 1e-9})
    assert not runner.differences("pump_pe600_design", {"accuracy_estimate": 1e-11}, {"accuracy_estimate": 4e-11})
    assert runner.differences("pump_pe600_design", {"a": [1.0]}, {"a": [1.0, 2.0]})
    assert runner.differences("pump_pe600_design", {"a": 1.0}, {"b": 1.0})
    assert {"pump_pe600_design", "compressor_k180_design", "spinup_robust_jeffcott"} <= set(runner.TESTED)


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("scene", sorted(runner.TESTED))
def test_a_fresh_run_gives_the_recorded_numbers(shipped_run, scene):
    """The scene's run (shared with the other slow tests of the worker: test_nulls runs every shipped scene)
    against docs/numbers.json, each value within its tolerance (run_numbers.TOLERANCE says which and why); the
    four longest scenes are left to ``python docs/run_numbers.py --check`` (run_numbers.UNTESTED)."""
    folder = shipped_run(scene)[1]
    fresh = runner.values(scene, json.loads((folder / "results.json").read_text(encoding="utf-8")))
    bad = runner.differences(scene, RECORDED["runs"][scene]["values"], fresh)
    assert not bad, f"{scene}: " + "; ".join(bad) + f" (regenerate: python docs/run_numbers.py {scene})"


def test_a_benchmark_run_names_the_command_that_writes_it_and_its_machine():
    """A benchmark JSON with a module of its name names ``python -m benchmarks NAME``; one that another module
    writes (the spin-up study scaling) names the file, not a command that does not exist."""
    startup = hooks.numbers_markdown("{{ run:startup }}")
    assert startup.startswith("`python -m benchmarks startup` on ") and "2 cores" in startup
    scaling = hooks.numbers_markdown("{{ run:spinup_study_scaling }}")
    assert scaling.startswith("`benchmarks/results/spinup_study_scaling.json` on ")


def test_the_benchmark_sections_quote_their_runs():
    """The benchmarks page's spin-up studies, spin-up OCP, stiff transient and lever numbers are placeholders
    into the benchmark JSONs (issue 24 item 2), not typed: e.g. the studies' wall times."""
    page = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    for key in ("spinup_studies.cases.2.wall_s", "spinup_ocp.cases.6.peer_s", "dynamics_integrators.cases.17.ratio",
                "statics_sweep.cases.11.cpu_ratio", "montecarlo_statics.cases.6.ratio", "spinup_study_scaling.cases.3"):
        assert "{{ n:" + key in page, key
    assert "113–138 s" not in page  # the studies' row typed from two stale runs


def test_the_accuracy_table_quotes_the_recorded_runs():
    """The work-precision page's accuracy estimates of the shipped scenes are recorded values (docs/numbers.json,
    compared within a factor 10 by the slow test), one per analysis of the table."""
    page = (ROOT / "docs" / "theory" / "workprecision.md").read_text(encoding="utf-8")
    for key in ("pump_pe600_dynamics.accuracy.frequency", "pump_pe600_dynamics.accuracy.stability",
                "pump_pe600_dynamics.accuracy.transient", "washer_liquid_balancer.accuracy.liquid_balancer",
                "hydroheel_wear.accuracy.estimate", "pump_pe600_montecarlo.accuracy.estimate"):
        assert "{{ n:" + key in page, key
        assert runner.tolerance(key.partition(".")[0], key.partition(".")[2]) == runner.ORDER, key
