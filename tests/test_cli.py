"""CLI and scenario validation: exit codes 0/2/3, one-line errors naming the field, results keys."""

import json

import pytest
import yaml

from autobal import cli, scenario
from autobal.analysis.run import solver_options
from autobal.errors import ScenarioError

PUMP = yaml.safe_load(scenario.resolve("pump_pe600_statics").read_text())


def write(tmp_path, data, name="scene.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data))
    return p


@pytest.mark.cli
@pytest.mark.parametrize(
    "path, value, message",
    [
        ("device.disc.inner_seal.clearance", "-0.35 mm", "device.disc.inner_seal.clearance: must be positive"),
        ("device.disc.inner_seal.clearance", "0.35 kg", "is not a length"),
        ("device.disc.inner_seal.clearance", 0.35, "has no unit"),
        ("device.operating.nominal_pressure", "32 parsecs", "is not a pressure"),
        ("device.operating.nominal_pressure", "thirty MPa", "cannot read"),
        ("device.disc.face.colour", "red", "device.disc.face.colour: unknown key"),
        ("device.disc.face.base_gap", None, "device.disc.face.base_gap: Field required"),
        ("device.fluid.density", "-1000 kg/m^3", "device.fluid.density: must be positive"),
        ("device.barrier.margin_ratio", -0.04, "device.barrier.margin_ratio: Input should be greater than 0"),
        ("device.medium", "plasma", "device.medium: Input should be 'liquid' or 'gas'"),
        ("analyses.statics.discharge_ratio.stop", 0.1, "stop must be larger than start"),
        ("device.disc.face.outer_diameter", "150 mm", "outer_diameter must be larger"),
    ],
)
def test_bad_input_one_line_naming_the_field(tmp_path, capsys, scene_edit, path, value, message):
    p = write(tmp_path, scene_edit(PUMP, path, value))
    with pytest.raises(ScenarioError, match=message.replace("(", r"\(")):
        scenario.load(p)
    assert cli.main(["check", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err


def test_units_are_converted_to_si():
    s = scenario.load("pump_pe600_statics")
    assert s.device.disc.inner_seal.clearance == pytest.approx(0.35e-3, rel=1e-12)
    assert s.device.operating.nominal_pressure == pytest.approx(32.2749e6, rel=1e-12)
    assert s.device.operating.impeller.speed == pytest.approx(6300 * 2 * 3.141592653589793 / 60, rel=1e-12)


@pytest.mark.cli
def test_missing_file_and_bad_yaml(tmp_path, capsys):
    assert cli.main(["check", str(tmp_path / "nope.yaml")]) == 2
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed")
    assert cli.main(["run", str(bad)]) == 2
    assert "not valid YAML" in capsys.readouterr().err


@pytest.mark.cli
def test_list_shows_shipped_scenarios(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "pump_pe600_statics" in out and "compressor_k180_statics" in out


@pytest.mark.cli
def test_run_pump_writes_documented_results(tmp_path):
    assert cli.main(["run", "pump_pe600_statics", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "results.json").read_text())
    st = res["statics"]
    cf, ex = st["closed_form"], st["exact"]
    # Appendix A values, to the printed digits
    assert abs(cf["dpsi_kr"] - 0.030) < 5e-4 and abs(cf["psi1_kr"] - 1.73) < 5e-3
    assert abs(cf["xi0"] - 1.294) < 5e-4 and abs(cf["psi2_0"] - 1.027) < 5e-4
    assert abs(cf["psi3_0"] - 0.513) < 5e-4 and cf["Q_e"] == pytest.approx(7.448e-3, rel=1e-4)
    assert ex["psi2_0"] == pytest.approx(1.0202057, abs=1e-7) and ex["u0"] == pytest.approx(0.9590975, abs=1e-7)
    for key in ("u0", "xi0", "psi2_0", "psi3_0", "psi_e0", "psi_cam0"):
        assert isinstance(ex[key], float)
    assert len(st["sweep"]["psi1"]) == 36 and len(st["sweep"]["u"]) == 36
    for f in ("statics_sweep.csv", "force_gap.csv", "fig_pressures.png", "fig_gap.png", "fig_flows.png"):
        assert (tmp_path / f).stat().st_size > 0


@pytest.mark.cli
def test_failed_solve_exits_3_with_status_and_last_iterate(tmp_path, capsys, monkeypatch):
    # an iteration limit the solve cannot meet: IPOPT really stops early
    monkeypatch.setitem(solver_options.defaults, "ipopt.max_iter", 1)
    assert cli.main(["run", "compressor_k180_statics", "--out", str(tmp_path)]) == 3
    err = capsys.readouterr().err
    assert "Maximum_Iterations_Exceeded" in err
    failed = json.loads((tmp_path / "failed_solve.json").read_text())
    assert failed["status"] == "Maximum_Iterations_Exceeded" and "psi2" in failed["last_iterate"]
