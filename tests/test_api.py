"""The Python API (autobal.load / autobal.run), the Result protocol and the output folder's life."""

import json

import matplotlib
import pytest
from matplotlib.figure import Figure

import autobal
from autobal import cli
from autobal.analysis.run import solver_options
from autobal.errors import ScenarioError, SolveError

pytestmark = pytest.mark.cli

SEAL = {"device.disc.outer_seal.length": "300 mm"}  # the README's example; 260 mm in the scene (Pavlenko 2014, App. A)


@pytest.fixture(scope="module")
def statics_run():
    return autobal.run(autobal.load("pump_pe600_statics", set=SEAL))


def test_api_gives_the_cli_numbers(statics_run, tmp_path):
    assert cli.main(["run", "pump_pe600_statics", "--out", str(tmp_path), "--quiet",
                     "--set", "device.disc.outer_seal.length=300 mm"]) == 0
    written = json.loads((tmp_path / "results.json").read_text())
    api = statics_run.to_dict()
    for key in ("u0", "z0", "xi0", "psi2_0", "Q_e"):
        assert written["statics"]["exact"][key] == pytest.approx(api["statics"]["exact"][key], rel=1e-12)
    assert written["meta"]["overrides"] == SEAL and written["meta"]["autobal_version"] == autobal.__version__
    assert written["meta"]["scene_si"]["device"]["disc"]["outer_seal"]["length"] == pytest.approx(0.3)


def test_override_reaches_the_physics(statics_run):
    """The README's longer outer seal (300 mm for 260 mm) throttles the cavity's outflow more: the face gap
    closes from 143.9 to 137.6 um and the barrier leakage falls from 11.29 to 11.04 L/s.  The base gap z_B alone
    only scales the gap (the face conductance is defined at u = 1 and scales as z_B^(3/2)): u0 changes as 1/z_B
    while the physical gap and pressures do not. A margin does change them."""
    nominal = autobal.run("pump_pe600_statics")["statics"]
    changed = statics_run["statics"]
    assert nominal.face_gap == pytest.approx(143.86e-6, rel=1e-4) and changed.face_gap == pytest.approx(137.59e-6,
                                                                                                         rel=1e-4)
    assert nominal.barrier_flow == pytest.approx(11.290e-3, rel=1e-4)
    assert changed.barrier_flow == pytest.approx(11.041e-3, rel=1e-4)
    based = autobal.run(autobal.load("pump_pe600_statics", set={"device.disc.face.base_gap": "0.18 mm"}))["statics"]
    assert based.to_dict()["exact"]["u0"] / nominal.to_dict()["exact"]["u0"] == pytest.approx(0.15 / 0.18, rel=1e-7)
    assert based.face_gap == pytest.approx(nominal.face_gap, rel=1e-7)
    assert based.face_gap == pytest.approx(based.to_dict()["exact"]["u0"] * 0.18e-3, rel=1e-12)  # z0 = u0 z_B
    assert based.chamber_pressures["p2"] == pytest.approx(nominal.chamber_pressures["p2"], rel=1e-9)
    wider = autobal.run(autobal.load("pump_pe600_statics", set={"device.barrier.margin_ratio": 0.05}))["statics"]
    assert wider.to_dict()["dpsi"] == 0.05
    assert wider.barrier_flow > 1.1 * nominal.barrier_flow and wider.face_gap != pytest.approx(nominal.face_gap)


def test_plot_returns_figures_and_leaves_the_backend(statics_run):
    matplotlib.use("svg")
    try:
        figs = statics_run["statics"].plot()
        assert len(figs) == 4 and all(isinstance(f, Figure) for f in figs)
        assert matplotlib.get_backend() == "svg"
        fig = Figure()
        assert statics_run["statics"].plot(ax=fig.add_subplot()) is fig
        assert len(fig.axes[0].lines) >= 8  # four pressures, exact and closed form
    finally:
        matplotlib.use("agg")


@pytest.mark.parametrize("value", ["-1 mm", "0 mm", "1 bar"])
def test_bad_override_is_refused_naming_the_field(value, capsys):
    with pytest.raises(ScenarioError, match=r"^set device\.disc\.face\.base_gap=.*device\.disc\.face\.base_gap"):
        autobal.load("pump_pe600_statics", set={"device.disc.face.base_gap": value})
    assert cli.main(["check", "pump_pe600_statics", "--set", f"device.disc.face.base_gap={value}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "device.disc.face.base_gap" in err[0]


def test_unknown_override_path_is_refused(capsys):
    assert cli.main(["check", "pump_pe600_statics", "--set", "device.disc.face.base_gapp=1 mm"]) == 2
    assert "base_gapp: unknown key" in capsys.readouterr().err
    assert cli.main(["check", "pump_pe600_statics", "--set", "novalue"]) == 2


def test_a_failed_run_replaces_earlier_results(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    assert cli.main(["run", "pump_pe600_statics", "--out", str(out), "--quiet"]) == 0
    assert (out / "results.json").exists() and (out / "fig_gap.png").exists()
    monkeypatch.setitem(solver_options.defaults, "ipopt.max_iter", 1)
    assert cli.main(["run", "compressor_k180_statics", "--out", str(out)]) == 3
    assert sorted(p.name for p in out.iterdir()) == ["autobal.log", "failed_solve.json", "report.html"]
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    monkeypatch.undo()
    assert cli.main(["run", "pump_pe600_statics", "--out", str(out), "--quiet"]) == 0
    assert not (out / "failed_solve.json").exists() and (out / "results.json").exists()
    assert not [p for p in tmp_path.iterdir() if p.name != "out"]  # no temporary folders left


def test_api_failed_solve_keeps_the_last_iterate(tmp_path, monkeypatch):
    monkeypatch.setitem(solver_options.defaults, "ipopt.max_iter", 1)
    with pytest.raises(SolveError) as err:
        autobal.run("compressor_k180_statics", out=tmp_path / "x")
    saved = json.loads((tmp_path / "x" / "failed_solve.json").read_text())
    assert saved["status"] == err.value.status == "Maximum_Iterations_Exceeded" and saved["analysis"] == "statics"


def test_bad_output_folders_are_refused_before_solving(tmp_path, capsys):
    afile = tmp_path / "file"
    afile.write_text("x")
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("x")
    for out, why in ((afile, "not a folder"), (foreign, "did not write"), ("/proc/autobal", "cannot be written")):
        assert cli.main(["run", "pump_pe600_statics", "--out", str(out)]) == 2
        err = capsys.readouterr()
        assert why in err.err and "statics at" not in err.out
    assert (foreign / "thesis.tex").exists() and afile.read_text() == "x"


def test_run_without_out_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = autobal.run("pump_pe600_statics")
    assert list(tmp_path.iterdir()) == [] and list(run) == ["statics"]
    saved = run.save(tmp_path / "later")
    assert json.loads((saved / "results.json").read_text())["statics"]["exact"]["z0"] == run["statics"].face_gap


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"autobal {autobal.__version__}"


def test_public_names_resolve():
    import autobal.models.device as device

    assert sorted(autobal.__all__) == sorted(dir(autobal))
    for name in autobal.__all__:
        assert getattr(autobal, name) is not None
    assert autobal.DeviceParams is device.DeviceParams


def test_a_run_uses_one_blas_thread_and_gives_it_back():
    """Bit-identical runs: during a run the BLAS of numpy and scipy has one thread (a multithreaded BLAS sums in a
    varying order; the ROSS spin-up scenes changed by up to 1 % from run to run), and the caller's setting is back
    afterwards."""
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads():
        return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}

    seen = []
    with threadpool_limits(2, user_api="blas"):
        autobal.run("compressor_k180_statics", on_result=lambda *_: seen.append(blas_threads()))
        after = blas_threads()
    assert seen and all(s == {1} for s in seen)
    assert after == {2}
