"""report.html of every shipped scene: self-contained, every figure embedded, verdicts shown, every
headline number with a unit; the units map of results.json; reports of failed runs; `autobal report`."""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser
from pathlib import Path

import pytest
import yaml

from autobal import cli, report, scenario

FAST = ("rig_table43_fit", "washer_liquid_balancer_nested")
SLOW = tuple(p.stem for p in scenario.shipped() if p.stem not in FAST)


class Page(HTMLParser):
    """What the tests look at in a report: links, images, headline cells, verdicts, text."""

    def __init__(self, html: str):
        super().__init__()
        self.links: list[tuple[str, str, str]] = []  # (tag, attribute, value)
        self.images: list[dict] = []
        self.headline_cells: list[dict] = []  # numeric cells of the headline tables
        self.verdicts: list[str] = []
        self.text: list[str] = []
        self._headline = 0
        self._verdict = None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("src", "href", "action", "data", "poster"):
            if key in a:
                self.links.append((tag, key, a[key]))
        if tag == "link" or tag == "script" and "src" in a:
            self.links.append((tag, "tag", a.get("href") or a.get("src") or ""))
        if tag == "img":
            self.images.append(a)
        if tag == "table":
            self._headline += "headline" in (a.get("class") or "")
        if tag == "td" and self._headline and "num" in (a.get("class") or ""):
            self.headline_cells.append(a)
        if tag == "li" and (a.get("class") or "") in ("ok", "bad", "info"):
            self._verdict = []

    def handle_endtag(self, tag):
        if tag == "table" and self._headline:
            self._headline = 0
        if tag == "li" and self._verdict is not None:
            self.verdicts.append("".join(self._verdict))
            self._verdict = None

    def handle_data(self, data):
        self.text.append(data)
        if self._verdict is not None:
            self._verdict.append(data)


def external(url: str) -> bool:
    return url.startswith(("http:", "https:", "//", "ftp:")) or "://" in url and not url.startswith("data:")


def check_report(folder: Path) -> Page:
    """The must-show checks of issue 13 on one output folder's report.html."""
    html = (folder / "report.html").read_text(encoding="utf-8")
    page = Page(html)
    assert not [link for link in page.links if external(link[2])], "report fetches something from elsewhere"
    assert not [link for link in page.links if link[0] in ("link", "script")], "external stylesheet or script"
    assert "@import" not in html and "url(" not in html.split("</style>")[0], "CSS pulls a resource"
    results = json.loads((folder / "results.json").read_text())
    figures = [f for f in results["files"] if f.endswith(".png")]
    assert figures, "a shipped scene without figures"
    srcs = [img["src"] for img in page.images]
    assert len(srcs) == len(figures)
    for src, name in zip(srcs, figures, strict=True):
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]) == (folder / name).read_bytes(), f"{name} not embedded as is"
    assert page.headline_cells, "no headline numbers"
    missing = [c for c in page.headline_cells if not c.get("data-unit") or c["data-unit"] == "?"]
    assert not missing, f"headline numbers without a unit: {missing[:3]}"
    assert page.verdicts, "no verdicts"
    body = " ".join(page.text)
    assert "could not be rendered" not in body
    for name in results["outputs"]:
        assert report.TITLES[name] in body
    assert results["units"], "results.json has no units map"
    return page


@pytest.fixture(scope="session")
def output(shipped_run):
    """``output(name)``: the output folder of the session's one run of a shipped scene."""
    return lambda name: shipped_run(name)[1]


@pytest.mark.cli
@pytest.mark.parametrize("name", FAST)
def test_report_of_a_fast_scene(output, name):
    check_report(output(name))


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_report_of_every_other_shipped_scene(output, name):
    page = check_report(output(name))
    body = " ".join(page.text)
    if name in report.published():
        assert "Comparison with the source's published values" in body


@pytest.mark.cli
@pytest.mark.slow
def test_dynamics_report_says_which_model_is_unstable(output):
    """Pavlenko (2014), App. A: the program model is unstable (+219.33 ± 1999.44i), the energy model stable."""
    page = check_report(output("pump_pe600_dynamics"))
    program = [v for v in page.verdicts if v.startswith("• source's program model")]  # validation: information
    assert any("219.33 ± 1999.4i" in v and "UNSTABLE" in v for v in program)
    assert any(v.startswith("✔ energy-consistent (nonlinear): stable") for v in page.verdicts)
    assert any("reproduces the published values" in v and "UNSTABLE" in v for v in program)


@pytest.mark.cli
def test_rerendering_gives_the_same_page(output):
    folder = output(FAST[0])
    first = (folder / "report.html").read_text()
    assert cli.main(["report", str(folder)]) == 0
    assert (folder / "report.html").read_text() == first


@pytest.mark.cli
def test_estimation_report_numbers(output):
    """Pavlenko (2014), Table 4.3: alpha = 1.6643 +- 0.0729 (least squares in u, tau_max = 2.75 fixed)."""
    page = check_report(output("rig_table43_fit"))
    body = " ".join(page.text)
    assert "1.6643" in body and "0.07295" in body  # 4 significant digits, as declared quantities are shown
    assert "Pavlenko (2014), Eq. (4.23)" in body


def test_units_map():
    """Dimensional keys get their SI unit, the source's groups '1', scanned parameters their own unit."""
    results = {"statics": {"exact": {"z0": 1e-4, "p2": 3e7, "Q_e": 0.01, "u0": 0.96, "kappa_s": 1.26},
                           "closed_form": {"Q_e_over_Q_n": 0.04}},
               "stability": {"maps": {"program": {"x": {"parameter": "cavity_volume", "values": [1e-6, 2e-6]}}},
                             "models": {"program": {"poles": {"real": [1.0], "imag": [2.0]}}}},
               "frequency": {"peaks": [{"omega": 1977.0, "amplitude": 25.2e-6}]},
               "spinup": {"time_of_peak_s": 3.6, "max_torque_N_m": 0.05, "peak_deflection_over_e": 12.3}}
    u = report.units(results)
    assert u == {"statics.exact.z0": "m", "statics.exact.p2": "Pa", "statics.exact.Q_e": "m^3/s",
                 "statics.exact.u0": "1", "statics.exact.kappa_s": "1", "statics.closed_form.Q_e_over_Q_n": "1",
                 "stability.maps.program.x.values": "m^3", "stability.models.program.poles.real": "1/s",
                 "stability.models.program.poles.imag": "rad/s", "frequency.peaks[].omega": "rad/s",
                 "frequency.peaks[].amplitude": "m", "spinup.time_of_peak_s": "s",
                 "spinup.max_torque_N_m": "N*m", "spinup.peak_deflection_over_e": "1"}


def test_cells_convert_to_the_display_unit():
    assert report.cell(32.2749e6, "Pa")["text"] == "32.275" and report.cell(1e6, "Pa")["unit"] == "MPa"
    assert report.cell(1.4386e-4, "m")["text"] == "0.14386" and report.cell(5.461e-3, "m^3")["unit"] == "L"
    assert report.cell(2e-6, "m") == {"text": "2", "unit": "µm", "num": True}
    assert report.cell(None, "Pa")["text"] == "—"
    assert report.cell(0.96, "1")["unit"] == "dimensionless"


@pytest.mark.cli
def test_failed_run_gets_a_report(tmp_path, capsys):
    """A failed solve's folder (failed_solve.json) gets a report that says what failed and why."""
    scene = {"name": "spin_small", "title": "small spin-up", "source": "test",
             "rotor": {"mass": "1 kg", "stiffness": "11025 N/m", "damping": "5 N*s/m", "eccentricity": "0.1 mm"},
             "analyses": {"spinup": {"start_speed": "40 rad/s", "final_speed": "210 rad/s", "horizon": "8.5 s",
                                     "max_acceleration": "40 rad/s^2", "intervals": 40, "multistart": False,
                                     "max_iterations": 3}}}
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "-q"]) == 3
    capsys.readouterr()
    page = Page((tmp_path / "out" / "report.html").read_text())
    body = " ".join(page.text)
    assert "Maximum_Iterations_Exceeded" in body and "iteration limit reached (3 iterations" in body
    assert "last iterate" in body and "small spin-up" in body
    assert not [link for link in page.links if external(link[2])]
    assert cli.main(["report", str(tmp_path / "out")]) == 0  # and again from the folder


@pytest.mark.cli
def test_report_of_a_folder_without_results_is_bad_input(tmp_path, capsys):
    assert cli.main(["report", str(tmp_path)]) == 2
    assert "results.json" in capsys.readouterr().err


def test_interrupted_run_gets_a_report(tmp_path):
    """interrupted.json: the report names the analysis that was running and what had completed."""
    (tmp_path / "interrupted.json").write_text(json.dumps(
        {"status": "interrupted", "analysis": "stability", "completed": ["frequency"],
         "scenario": "pump_pe600_dynamics", "title": "Pump PE 600-300"}))
    body = " ".join(Page(report.html(tmp_path)).text)
    assert "The run did not complete: interrupted" in body and "stability" in body
    assert "Completed before the interrupt: frequency" in body
