"""Hostile and new-user unit input through the command line (issue #25, items 1 and 6): rotational units
that were silently off by 2 pi, booleans taken as 1, and quantity strings built to make the unit grammar
backtrack. Each ends with exit 2 and one short line on stderr naming the field, no traceback; the wall
bound is only a hang guard (the machine is shared)."""

import copy
import time

import pytest
import yaml

from autobal import cli, scenario

PUMP = scenario.read(scenario.resolve("pump_pe600_statics"))
SPEED = "device.operating.impeller.speed"


def refused(capsys, args) -> str:
    """The one stderr line of ``autobal check ARGS`` (exit 2, no traceback, within a hang guard)."""
    t0 = time.perf_counter()
    code = cli.main(["check", *args])
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    assert len(lines[0]) < 400, f"{len(lines[0])} characters: the input is echoed whole"
    assert elapsed < 5.0, f"{elapsed:.1f} s (a hang?)"
    return lines[0]


def scene_file(tmp_path, path: str, text: str):
    """The pump scene with the raw YAML ``text`` as the value at ``path``."""
    data = copy.deepcopy(PUMP)
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[key]
    node[last] = "@@VALUE@@"
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(data).replace("'@@VALUE@@'", text))
    return p


@pytest.mark.cli
@pytest.mark.parametrize("value, shown", [
    ("105 Hz", "659.73 rad/s (6300 rpm)"),
    ("6300 1/min", "659.73 rad/s (6300 rpm)"),
    ("6300 r/min", "659.73 rad/s (6300 rpm)"),
    ("659.734 rad/s", "659.73 rad/s (6300 rpm)"),
])
def test_the_silently_wrong_speeds_are_read_as_omega_and_shown(capsys, value, shown):
    assert cli.main(["check", "pump_pe600_statics", "--set", f"{SPEED}={value}"]) == 0
    assert f"{SPEED} = {shown}" in capsys.readouterr().out


@pytest.mark.cli
def test_inverse_seconds_on_a_speed_are_refused_naming_rad_per_second_and_hertz(capsys):
    line = refused(capsys, ["pump_pe600_statics", "--set", f"{SPEED}=659.7 1/s"])
    assert SPEED in line and "ambiguous" in line and "rad/s" in line and "Hz" in line


@pytest.mark.cli
@pytest.mark.parametrize("path, word", [
    ("device.barrier.margin_ratio", "yes"),  # float
    ("device.operating.impeller.stages", "on"),  # int
    ("analyses.statics.discharge_ratio.points", "true"),  # int with bounds
])
def test_yaml_booleans_are_refused_where_a_number_is_expected(tmp_path, capsys, path, word):
    line = refused(capsys, [str(scene_file(tmp_path, path, word))])
    assert f"{path}: a boolean where a number is expected" in line


@pytest.mark.cli
def test_a_long_quantity_with_a_newline_in_the_file(tmp_path, capsys):
    text = '"6300 ' + "r" * 3500 + '\\npm"'  # 3.5 kB, a newline inside (a YAML escape)
    line = refused(capsys, [str(scene_file(tmp_path, SPEED, text))])
    assert SPEED in line and "at most 100 characters" in line


@pytest.mark.cli
@pytest.mark.parametrize("value", [
    "6300" + " " * 130_000 + "rpm",
    "6300 rpm" + " " * 130_000 + "x",
    "6300 r" + "\t " * 20_000 + "x",
    "6300 " + "m " * 20_000 + "\n",
])
def test_a_huge_quantity_on_the_command_line(capsys, value):
    line = refused(capsys, ["pump_pe600_statics", "--set", f"{SPEED}={value}"])
    assert SPEED in line and "characters" in line


@pytest.mark.parametrize("value", [
    "1 " + "m " * 48 + "!",  # a run of names, failing at the end
    "1 m" + " " * 95 + "!",  # a run of spaces, failing at the end
    "1 " + "m*" * 48 + "*",
    "1 " + "m^2 " * 24 + "^",
    "1" * 99 + "!",
])
def test_the_grammar_refuses_the_worst_strings_at_the_cap_at_once(value):
    from autobal import units

    t0 = time.process_time()
    for kind in ("length", "angular speed", "rate"):
        with pytest.raises(ValueError):
            units.to_si(value, kind)
    assert time.process_time() - t0 < 1.0  # a hang guard: quadratic backtracking took seconds at 20 kB
