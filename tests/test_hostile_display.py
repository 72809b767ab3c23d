"""Hostile input to the display units and the printed report: a unit with terminal escapes or of any length, a
display section of the wrong type, a results.json whose display section or title is built to break out of the
report's stylesheet.  Each is refused with exit 2 and one short line, or shown harmlessly."""

from __future__ import annotations

import json
import shutil

import pytest
import yaml

from autobal import cli, scenario

PUMP = yaml.safe_load(scenario.resolve("pump_pe600_statics").read_text())


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert "\x1b" not in err and "Traceback" not in err
    return err.strip()


@pytest.mark.cli
@pytest.mark.parametrize("units", [
    "pressure=\x1b[31mbar\x1b[0m",  # terminal escapes
    "pressure=" + "b" * 20_000,  # a unit of any length
    "flow=m3/h\npressure=bar",  # a line break inside
    "=bar", ",,,", "pressure==bar", "len\x00gth=mm",
])
def test_a_hostile_units_option_is_one_line(capsys, units):
    assert cli.main(["run", "pump_pe600_statics", "--units", units]) == 2
    line = one_line(capsys)
    assert line.startswith("autobal: bad input: --units") and len(line) < 700, line


@pytest.mark.cli
@pytest.mark.parametrize("display, message", [
    ({"pressure": 5}, "display.pressure: Input should be a valid string"),
    ({"pressure": True}, "display.pressure: Input should be a valid string"),
    ({"pressure": ["bar"]}, "display.pressure: Input should be a valid string"),
    ("bar", "display: Input should be a valid dictionary"),
    ({"pressure": "bar; rm -rf /"}, "display.pressure: 'bar; rm -rf /' is not a unit of pressure"),
])
def test_a_display_section_of_the_wrong_type_is_one_line(tmp_path, capsys, display, message):
    scene = tmp_path / "pump.yaml"
    scene.write_text(yaml.safe_dump(PUMP | {"display": display}))
    assert cli.main(["check", str(scene)]) == 2
    assert message in one_line(capsys)


@pytest.mark.cli
def test_a_results_json_with_a_hostile_display_section_is_refused_by_report(shipped_run, tmp_path, capsys):
    _, default = shipped_run("pump_pe600_statics")
    folder = tmp_path / "hostile"
    shutil.copytree(default, folder)
    data = json.loads((folder / "results.json").read_text())
    data["meta"]["scene_si"]["display"] = {"pressure": "</style><script>alert(1)</script>"}
    (folder / "results.json").write_text(json.dumps(data))
    assert cli.main(["report", str(folder)]) == 2
    line = one_line(capsys)
    assert "results.json meta.scene_si.display" in line and "is not a unit of pressure" in line
    data["meta"]["scene_si"]["display"] = "bar"  # not a mapping: no choice, the declared units
    data["title"] = 'x"; } @page { @top-left { content: "pwned"; } } </style><script>alert(1)</script>'
    (folder / "results.json").write_text(json.dumps(data))
    assert cli.main(["report", str(folder)]) == 0
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert page.count("</style>") == 1 and "<script>" not in page
    style = page[page.index("<style>"):page.index("</style>")]
    assert '"pwned"' not in style and "alert(1)" not in style
