"""Hostile input: bad files, bad names, bad values and units, unbounded work.

Every case must give exit code 2 with one line on stderr that names the field (or the file's fault),
no traceback, and nothing written anywhere (``check``) or outside the output folder (``run``).
A hypothesis test mutates the shipped scenes and asserts that validation only ever accepts or refuses
with one line (exit 0 or 2), never crashes.
"""

import copy
import os
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from autobal import analyses, cli, scenario

HOSTILE = Path(__file__).parent / "hostile"
PUMP = yaml.safe_load(scenario.resolve("pump_pe600_statics").read_text())
MC = yaml.safe_load(scenario.resolve("pump_pe600_montecarlo").read_text())
DYN = yaml.safe_load(scenario.resolve("pump_pe600_dynamics").read_text())
SPIN = yaml.safe_load(scenario.resolve("spinup_jeffcott_deadline_5s").read_text())


def edited(base: dict, path: str, value) -> dict:
    """A copy of ``base`` with the dotted ``path`` set to ``value`` (deleted when value is ...)."""
    out = copy.deepcopy(base)
    *parents, last = path.split(".")
    node = out
    for k in parents:
        node = node[k]
    if value is ...:
        del node[last]
    else:
        node[last] = value
    return out


# (case id, base scene, dotted path, new value, text the one-line message must contain)
VALUES = [
    ("inf_pressure", PUMP, "device.operating.nominal_pressure", "inf MPa", "device.operating.nominal_pressure"),
    ("nan_pressure", PUMP, "device.operating.nominal_pressure", "nan MPa", "must be a finite number"),
    ("overflowing_pressure", PUMP, "device.operating.nominal_pressure", "1e308 MPa", "overflows"),
    ("exponent_overflow", PUMP, "device.regulator.supply_pressure", "1e999 Pa", "finite"),
    ("power_expression", PUMP, "device.operating.nominal_pressure", "10**400 Pa", "is not a unit"),
    ("tower_of_powers", PUMP, "device.operating.nominal_pressure", "10**10**10 Pa", "is not a unit"),
    ("python_in_unit", PUMP, "device.operating.nominal_pressure", "__import__('os') Pa", "cannot read"),
    ("statement_after_value", PUMP, "device.disc.face.base_gap", "0.15 mm; import os", "not a unit"),
    ("parenthesised_unit", PUMP, "device.disc.face.base_gap", "0.15 (mm)", "not a unit"),
    ("unit_with_power_100", PUMP, "device.disc.face.base_gap", "0.15 mm^100", "not a unit"),
    ("unknown_unit", PUMP, "device.disc.face.base_gap", "0.15 furlongz", "not a known unit"),
    ("wrong_dimension", PUMP, "device.disc.face.base_gap", "5 m*kg", "is not a length: expected a unit like"),
    ("parsec_gap", PUMP, "device.disc.face.base_gap", "0.35 parsec", "outside the physical range"),
    ("kilometre_gap", PUMP, "device.disc.face.base_gap", "2 km", "outside the physical range"),
    ("negative_clearance", PUMP, "device.disc.inner_seal.clearance", "-0.35 mm", "must be positive"),
    ("zero_gap", PUMP, "device.disc.face.base_gap", "0 mm", "must be positive"),
    ("number_without_unit", PUMP, "device.disc.face.base_gap", 0.15, "has no unit"),
    ("unit_without_number", PUMP, "device.disc.face.base_gap", "mm", "cannot read"),
    ("boolean_length", PUMP, "device.disc.face.base_gap", True, "device.disc.face.base_gap"),
    ("list_length", PUMP, "device.disc.face.base_gap", ["0.15 mm"], "device.disc.face.base_gap"),
    ("mapping_pressure", PUMP, "device.operating.nominal_pressure", {"value": 32}, "nominal_pressure"),
    ("inf_ratio", PUMP, "device.barrier.margin_ratio", float("inf"), "device.barrier.margin_ratio"),
    ("nan_ratio", PUMP, "device.operating.thrust_ratio", float("nan"), "device.operating.thrust_ratio"),
    ("huge_ratio", PUMP, "device.barrier.margin_ratio", 1e308, "device.barrier.margin_ratio"),
    ("huge_string_ratio", PUMP, "device.barrier.margin_ratio", "1e400", "device.barrier.margin_ratio"),
    ("huge_operating_ratio", PUMP, "analyses.statics.operating_ratio", 1e6, "analyses.statics.operating_ratio"),
    ("negative_ratio", PUMP, "device.barrier.margin_ratio", -0.04, "device.barrier.margin_ratio"),
    ("string_ratio", PUMP, "device.barrier.margin_ratio", "four percent", "device.barrier.margin_ratio"),
    ("huge_stages", PUMP, "device.operating.impeller.stages", 1e308, "device.operating.impeller.stages"),
    ("fractional_stages", PUMP, "device.operating.impeller.stages", 2.5, "device.operating.impeller.stages"),
    ("long_title", PUMP, "title", "x" * 10_000, "title"),
    ("name_traversal", PUMP, "name", "../../../../tmp/x", "name"),
    ("name_absolute", PUMP, "name", "/tmp/x", "name"),
    ("name_separator", PUMP, "name", "a/b", "name"),
    ("name_backslash", PUMP, "name", "a\\b", "name"),
    ("name_dotdot", PUMP, "name", "..", "name"),
    ("name_hidden_dotdot", PUMP, "name", "a..b", "name"),
    ("name_empty", PUMP, "name", "", "name"),
    ("name_newline", PUMP, "name", "a\nb", "name"),
    ("name_number", PUMP, "name", 123, "name"),
    ("no_analysis", PUMP, "analyses", {}, "analyses: the scene names no analysis"),
    ("analyses_missing", PUMP, "analyses", ..., "analyses: Field required"),
    ("unknown_analysis", PUMP, "analyses.fourier", {"points": 3}, "analyses.fourier: unknown key"),
    ("statics_without_device", PUMP, "device", ..., "analyses.statics needs a device section"),
    ("sweep_points_unbounded", PUMP, "analyses.statics.discharge_ratio.points", 100_000_000,
     "analyses.statics.discharge_ratio.points"),
    ("force_gap_points_unbounded", PUMP, "analyses.statics.force_gap_points", 100_000_000,
     "analyses.statics.force_gap_points"),
    ("sweep_stop_huge", PUMP, "analyses.statics.discharge_ratio.stop", 1e300, "analyses.statics.discharge_ratio"),
    ("montecarlo_samples_unbounded", MC, "analyses.montecarlo.samples", 10_000_000, "analyses.montecarlo.samples"),
    ("montecarlo_many_pressures", MC, "analyses.montecarlo.discharge_ratio", [1.0] * 1000,
     "analyses.montecarlo.discharge_ratio"),
    ("afc_samples_unbounded", MC, "analyses.montecarlo.afc.samples", 100_000_000, "analyses.montecarlo.afc.samples"),
    ("spinup_intervals_unbounded", SPIN, "analyses.spinup.intervals", 1_000_000, "analyses.spinup.intervals"),
    ("spinup_inf_horizon", SPIN, "analyses.spinup.horizon", "inf s", "analyses.spinup.horizon"),
    ("rotor_negative_mass", SPIN, "rotor.mass", "-1 kg", "rotor.mass"),
    ("map_points_unbounded", DYN, "analyses.stability.map.x.points", 10_000, "analyses.stability.map.x.points"),
    ("map_axis_inf", DYN, "analyses.stability.map.x.start", "inf m^3", "analyses.stability.map"),
    ("omega_points_unbounded", DYN, "analyses.frequency.omega.points", 10**9, "analyses.frequency.omega.points"),
    ("transient_points_unbounded", DYN, "analyses.transient.points", 10**9, "analyses.transient.points"),
]

# (case id, file in tests/hostile/, text the one-line message must contain)
FILES = [
    ("binary_file", "binary.yaml", "binary file"),
    ("latin1_file", "latin1.yaml", "not UTF-8"),
    ("duplicate_key", "duplicate_top_key.yaml", "duplicate key 'name' at line 4 (first at line 2)"),
    ("billion_laughs", "billion_laughs.yaml", "more than 100000 values"),
    ("python_tag", "python_tag.yaml", "not valid YAML"),
    ("tab_indentation", "tabs.yaml", "not valid YAML"),
    ("name_traversal_file", "name_traversal.yaml", "name: '../../../../tmp/autobal_escape' is not a plain"),
    ("name_absolute_file", "name_absolute.yaml", "name: '/tmp/autobal_escape' is not a plain"),
    ("no_analysis_file", "no_analysis.yaml", "analyses: the scene names no analysis"),
]


def generated(tmp: Path, case: str) -> tuple[Path, str]:
    """Files made on the fly: (path, text the message must contain)."""
    if case == "utf16_file":
        p = tmp / "utf16.yaml"
        p.write_bytes(yaml.safe_dump(PUMP).encode("utf-16"))
        return p, "binary file"
    if case == "empty_file":
        p = tmp / "empty.yaml"
        p.write_text("")
        return p, "a YAML mapping"
    if case == "list_file":
        p = tmp / "list.yaml"
        p.write_text("- name: x\n- title: y\n")
        return p, "a YAML mapping"
    if case == "unclosed_bracket":
        p = tmp / "bad.yaml"
        p.write_text("name: [unclosed\n")
        return p, "not valid YAML"
    if case == "duplicate_nested_key":
        text = scenario.resolve("pump_pe600_statics").read_text()
        text = text.replace("base_gap: 0.15 mm,", "base_gap: 0.15 mm, base_gap: 0.2 mm,")
        p = tmp / "dup.yaml"
        p.write_text(text)
        return p, "duplicate key 'base_gap' at line 20"
    if case == "huge_file":
        p = tmp / "huge.yaml"
        p.write_text("name: x\ntitle: y\n" + "# padding\n" * 200_000)
        return p, "a scenario is a YAML text of at most"
    if case == "deep_nesting":
        p = tmp / "deep.yaml"
        p.write_text("name: " + "[" * 100_000 + "]" * 100_000 + "\n")
        return p, "deep.yaml"
    if case == "folder":
        (tmp / "folder.yaml").mkdir()
        return tmp / "folder.yaml", "is a folder"
    if case == "missing_file":
        return tmp / "nope.yaml", "no such scenario file"
    raise KeyError(case)


GENERATED = ["utf16_file", "empty_file", "list_file", "unclosed_bracket", "duplicate_nested_key", "huge_file",
             "deep_nesting", "folder", "missing_file"]


def case_file(tmp: Path, kind: str, case) -> tuple[Path, str]:
    if kind == "value":
        _, base, path, value, text = case
        p = tmp / "scene.yaml"
        p.write_text(yaml.safe_dump(edited(base, path, value), allow_unicode=True))
        return p, text
    if kind == "file":
        return HOSTILE / case[1], case[2]
    return generated(tmp, case)


ALL = ([pytest.param("value", c, id=c[0]) for c in VALUES] + [pytest.param("file", c, id=c[0]) for c in FILES]
       + [pytest.param("generated", c, id=c) for c in GENERATED])


def test_at_least_forty_hostile_inputs():
    assert len(ALL) >= 40


def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*")}


@pytest.mark.cli
@pytest.mark.parametrize("kind, case", ALL)
def test_hostile_input_is_refused_with_one_line(tmp_path, capsys, monkeypatch, kind, case):
    work = tmp_path / "work"
    work.mkdir()
    path, text = case_file(tmp_path, kind, case)
    monkeypatch.chdir(work)
    t0 = time.perf_counter()
    code = cli.main(["check", str(path)])
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert text in lines[0], lines[0]
    assert elapsed < 30, f"validation took {elapsed:.1f} s (a hang?)"
    assert files_under(work) == set(), "check wrote files"
    assert not Path("/tmp/autobal_hostile_pwned").exists()


@pytest.mark.cli
@pytest.mark.parametrize("kind, case", [pytest.param("value", c, id=c[0]) for c in VALUES if c[0].startswith("name")]
                         + [pytest.param("file", c, id=c[0]) for c in FILES[:3]])
def test_hostile_run_writes_nothing_outside_its_output_folder(tmp_path, capsys, monkeypatch, kind, case):
    work = tmp_path / "work"
    work.mkdir()
    path, _ = case_file(tmp_path, kind, case)
    monkeypatch.chdir(work)
    before = files_under(tmp_path.parent)
    assert cli.main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert files_under(work) == set()
    assert files_under(tmp_path.parent) - before == set()
    assert not Path("/tmp/x").exists() and not Path("/tmp/autobal_escape").exists()


def test_a_unit_expression_is_never_evaluated():
    """pint would evaluate 10**10**10 (and hang); the strict grammar refuses it at once."""
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="is not a unit"):
        scenario.Scenario.model_validate(edited(PUMP, "device.operating.nominal_pressure", "10**10**10 Pa"))
    assert time.perf_counter() - t0 < 5.0  # pint would not return at all


# ---- mutations of the shipped scenes --------------------------------------------------------------------

SHIPPED = {p.stem: yaml.safe_load(p.read_text()) for p in scenario.shipped()}
NASTY = [float("inf"), float("-inf"), float("nan"), 1e308, -1e308, 1e-308, -1.0, 0, 10**30, "", "x" * 300,
         True, None, [], {}, [1, 2], "inf MPa", "nan mm", "1e308 Pa", "-5 mm", "3 kg", "10**10**10 Pa",
         "../../x", "0.1 rpm", "7 s", "1 m^3"]
UNITS = ["MPa", "mm", "kg", "N*s/m", "rad/s", "s", "m^3", "Pa*s", "kg/m^3", "1/s", "parsec", "degC", ""]


def leaves(node, prefix=()):
    """Dotted paths to every key of a scene (mappings only)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield (*prefix, k)
            yield from leaves(v, (*prefix, k))


@st.composite
def mutated_scene(draw):
    name = draw(st.sampled_from(sorted(SHIPPED)))
    data = copy.deepcopy(SHIPPED[name])
    paths = list(leaves(data))
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(paths))
        node = data
        try:
            for k in path[:-1]:
                node = node[k]
        except (KeyError, TypeError):
            continue
        if not isinstance(node, dict) or path[-1] not in node:
            continue
        key, old = path[-1], node[path[-1]]
        action = draw(st.sampled_from(["drop", "rename", "unit", "nasty", "type"]))
        if action == "drop":
            del node[key]
        elif action == "rename":
            node[key + draw(st.sampled_from(["_x", "s", "X"]))] = node.pop(key)
        elif action == "unit" and isinstance(old, str) and " " in old:
            node[key] = old.split(" ")[0] + " " + draw(st.sampled_from(UNITS))
        elif action == "nasty":
            node[key] = draw(st.sampled_from(NASTY))
        else:
            node[key] = draw(st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
                                       st.text(max_size=20), st.booleans(), st.lists(st.integers(), max_size=3)))
    return data


@pytest.mark.slow  # > 5 s; the capability is also checked by the default run
@pytest.mark.cli
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                   HealthCheck.too_slow])
@given(data=mutated_scene())
def test_mutated_shipped_scenes_are_accepted_or_refused_in_one_line(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("mut")
    p = folder / "scene.yaml"
    p.write_text(yaml.safe_dump(data, allow_unicode=True))
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = cli.main(["check", str(p)])
    assert code in (0, 2), err.getvalue()
    if code == 2:
        assert len(err.getvalue().strip().splitlines()) == 1, err.getvalue()
    assert "Traceback" not in err.getvalue()


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("path, value", [
    ("device.barrier.margin_ratio", 9.0),
    ("device.operating.thrust_ratio", 50.0),
    ("device.disc.face.base_gap", "1e-9 m"),
    ("device.regulator.supply_pressure", "1e11 Pa"),
    ("analyses.statics.discharge_ratio.stop", 100.0),
])
def test_extreme_but_valid_values_run_to_a_result_or_a_failed_solve(tmp_path, capsys, path, value):
    """Values inside the bounds but far from any design: exit 0 or 3 (failed solve), never a traceback."""
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(edited(PUMP, path, value)))
    code = cli.main(["run", str(p), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code in (0, 3), err
    assert "Traceback" not in err
    assert os.listdir(tmp_path) == ["scene.yaml", "out"] or sorted(os.listdir(tmp_path)) == ["out", "scene.yaml"]


# ---- work limits ---------------------------------------------------------------------------------------


def test_shipped_scenes_are_predicted_long_only_when_they_are():
    long = {"spinup_ross_rotor"}  # about 90 s (ROSS, issue #32): it says so before it starts
    for p in scenario.shipped():
        assert (analyses.long_run_note(scenario.load(p)) is not None) == (p.stem in long), p.stem


@pytest.mark.parametrize("base, path, value, analysis", [
    (PUMP, "analyses.statics.discharge_ratio.points", 100_000, "statics"),
    (MC, "analyses.montecarlo.samples", 2_000_000, "montecarlo"),
    (SPIN, "analyses.spinup.intervals", 5000, "spinup"),
    (DYN, "analyses.stability.map.x.points", 400, "stability"),
])
def test_a_run_at_the_size_bounds_is_announced_with_its_estimate(tmp_path, base, path, value, analysis):
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(edited(base, path, value)))
    scn = scenario.load(p)
    small = analyses.estimate_seconds(scenario.load(scenario.resolve(base["name"])))[analysis]
    big = analyses.estimate_seconds(scn)[analysis]
    assert big > 60 and big > 5 * small
    note = analyses.long_run_note(scn)
    assert note.startswith("this run is estimated to take about") and f"{analysis} " in note


@pytest.mark.cli
@pytest.mark.parametrize("override, text", [
    ("name=../../x", "set name=../../x: name:"),
    ("device.disc.face.base_gap=inf mm", "set device.disc.face.base_gap=inf mm: device.disc.face.base_gap:"),
    ("device.disc.face.base_gap=10**10**10 m", "is not a unit"),
    ("device.barrier.margin_ratio=.nan", "set device.barrier.margin_ratio=.nan: device.barrier.margin_ratio:"),
    ("analyses.statics.force_gap_points=1e12", "analyses.statics.force_gap_points"),
])
def test_hostile_overrides_are_refused_like_the_file(capsys, override, text):
    assert cli.main(["check", "pump_pe600_statics", "--set", override]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and text in err, err
