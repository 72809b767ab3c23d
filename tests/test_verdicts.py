"""One verdict per analysis (issue #23 item 4): the summary of every shipped scene's report.html holds exactly one
verdict per analysis, the headline model's; the source's models (chain form, hand model, program model, the
thesis as printed) appear only in the "Validation against the source" part."""

from __future__ import annotations

import json
import math
from html.parser import HTMLParser

import pytest

from autobal import report, scenario
from autobal.analysis.numerics.frequency import MODEL_LABELS
from autobal.analysis.run.quantities import significant

FAST = ("pump_pe600_statics", "pump_pe600_dynamics", "rig_table43_fit", "washer_liquid_balancer_nested")
SLOW = tuple(p.stem for p in scenario.shipped() if p.stem not in FAST)
SOURCE_LABELS = [MODEL_LABELS[m] for m in report.SOURCE_MODELS]


class Parts(HTMLParser):
    """The summary's verdicts (analysis, text) and the page's text inside and outside the validation parts."""

    def __init__(self, html: str):
        super().__init__()
        self.summary: list[tuple[str, str]] = []
        self.inside: list[str] = []
        self.outside: list[str] = []
        self._depth = 0  # nesting of div inside a validation part
        self._item = None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "div" and (self._depth or "validation" in (a.get("class") or "").split()):
            self._depth += 1
        if tag == "li" and "data-analysis" in a:
            self._item = (a["data-analysis"], [])

    def handle_endtag(self, tag):
        if tag == "div" and self._depth:
            self._depth -= 1
        if tag == "li" and self._item is not None:
            self.summary.append((self._item[0], "".join(self._item[1])))
            self._item = None

    def handle_data(self, data):
        (self.inside if self._depth else self.outside).append(data)
        if self._item is not None:
            self._item[1].append(data)


def check_one_verdict(folder) -> Parts:
    parts = Parts((folder / "report.html").read_text(encoding="utf-8"))
    analyses = json.loads((folder / "results.json").read_text())["outputs"]
    assert sorted(a for a, _ in parts.summary) == sorted(analyses), "not exactly one summary verdict per analysis"
    outside = " ".join(parts.outside)
    leaked = [label for label in SOURCE_LABELS if label in outside]
    assert not leaked, f"the source's models outside the validation part: {leaked}"
    return parts


@pytest.mark.cli
@pytest.mark.parametrize("name", FAST)
def test_one_verdict_per_analysis_of_a_fast_scene(shipped_run, name):
    check_one_verdict(shipped_run(name)[1])


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_one_verdict_per_analysis_of_every_other_scene(shipped_run, name):
    check_one_verdict(shipped_run(name)[1])


@pytest.mark.cli
def test_the_pump_is_stable_and_its_source_models_are_validation(shipped_run):
    """Pavlenko (2014), App. A: the program model is unstable (+219.33 ± 1999.4i); the energy-consistent model is
    stable (-82.6 1/s) and alone judges the machine, in results.json as in the report."""
    run, folder = shipped_run("pump_pe600_dynamics")
    st = run["stability"]
    assert st.stable is True and st.to_dict()["stable"] is True and st.decay_rate == pytest.approx(82.6, abs=0.1)
    parts = check_one_verdict(folder)
    verdicts = dict(parts.summary)
    assert verdicts["stability"].startswith("✔") and "decay at 82.64 1/s" in verdicts["stability"]
    inside = " ".join(parts.inside)
    assert "219.33 ± 1999.4i" in inside and "Validation against the source" in inside


@pytest.mark.cli
@pytest.mark.slow
def test_design_report_says_the_optimum_is_more_unstable_under_the_source_models(shipped_run):
    parts = check_one_verdict(shipped_run("pump_pe600_design")[1])
    verdict = dict(parts.summary)["design"]
    assert verdict.startswith("✔") and "optimum design, energy-consistent (nonlinear): stable" in verdict
    inside = " ".join(parts.inside)
    for label in ("chain form (2.40)/(2.111): spectral abscissa", "source's program model (App. A/B): spectral"):
        line = inside[inside.index(label):].split("•")[0]
        assert "MORE unstable than the nominal design" in line, line


def test_an_analysis_without_a_criterion_still_has_one_summary_line():
    sec = report.Section("x", {}, {})
    assert sec.overall()["ok"] is None and "no pass/fail criterion" in sec.overall()["text"]
    sec.verdict(None, "objective: peak deflection")
    assert sec.overall() == {"ok": None, "text": "objective: peak deflection"}
    sec.verdict(True, "re-simulated within 1 %")
    sec.verdict(False, "limit violated")
    assert sec.overall()["text"] == "limit violated"  # a failed check before a passed one
    sec.conclude(True, "the headline")
    assert sec.overall()["text"] == "the headline" and sec.verdicts[0]["text"] == "the headline"


def test_a_failed_analysis_never_has_an_ok_verdict():
    """A block with failures (an integrator failure, a residual above tolerance) gets a failed summary line, whatever
    its section concludes."""
    results = {"scenario": "x", "statics": {"failures": ["the exact statics did not solve at psi1 = 1.2"]}}
    (sec,) = report.sections(results)
    assert sec["overall"] == {"ok": False, "text": "FAILED: the exact statics did not solve at psi1 = 1.2"}


@pytest.mark.cli
def test_frequency_summary_is_one_verdict_in_display_units_and_the_source_apart(shipped_run):
    """The AFC summary opens with the headline model's verdict (energy-consistent, physical forcing), resonances in
    rad/s with Hz beside and amplitudes in µm, as results.json has them; the source's models only below the
    validation line."""
    run, folder = shipped_run("pump_pe600_dynamics")
    text = run["frequency"].summary()
    h = json.loads((folder / "results.json").read_text())["frequency"]["headline"]
    first, resonance, amplitude = text.splitlines()[:3]
    omega, amp = h["peaks"][0]["omega"], h["peaks"][0]["amplitude"] / 1e-6  # m in results.json
    assert first == "frequency response: energy-consistent (nonlinear), physical forcing: stable"
    assert resonance.endswith(f"ω_I, ω_II {significant(omega)} rad/s ({significant(omega / (2 * math.pi))} Hz)")
    assert amplitude.endswith(f"A_I, A_II {significant(amp)} µm") and text.count(f"{significant(amp)} µm") == 1
    head, _, validation = text.partition("validation against the source")
    assert "UNSTABLE" not in head and "program model" not in head and "program model" in validation
    assert " um" not in text
