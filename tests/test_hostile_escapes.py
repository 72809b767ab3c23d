"""Hostile input that escaped before (issue #32, items 7 and 8): nothing silently dropped, nothing written outside
the output folder, no file content quoted, every validation of ``run`` seen by ``check``, no number for a case that
has none, and Ctrl-C/SIGTERM obeyed within 2 s also in the ROSS spin-up.  Each case ends with its exit code and one
line naming what is wrong (tests/hostile.py)."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autobal import analyses, cli, scenario
from autobal.analyses.stability import Stability
from autobal.ocp import spinup as S
from autobal.paths import SCENARIO_DIR
from tests.hostile import refused
from tests.test_interrupt import interrupted_run

pytestmark = pytest.mark.cli
FAST = "pump_pe600_statics"


def one_line(capsys, code: int, *args: str) -> str:
    """``autobal args`` exits ``code`` with exactly one line on stderr, which is returned."""
    assert cli.main(list(args)) == code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def scene_with(tmp_path: Path, shipped: str, analyses_text: str | None = None, replace: tuple = ()) -> Path:
    """A copy of a shipped scene, its ``analyses:`` section replaced by ``analyses_text`` and the ``replace`` pairs
    (old, new) substituted."""
    text = (SCENARIO_DIR / f"{shipped}.yaml").read_text()
    if analyses_text is not None:
        text = text[:text.index("\nanalyses:")] + "\nanalyses:\n" + analyses_text
    for old, new in replace:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return path


# ---- an empty analysis key -------------------------------------------------------------------------------------
def test_an_empty_analysis_key_runs_the_analysis_with_its_defaults(tmp_path, capsys):
    path = scene_with(tmp_path, "pump_pe600_dynamics", "  stability:\n")
    assert cli.main(["check", str(path)]) == 0
    assert "valid; analyses: stability" in capsys.readouterr().out
    assert scenario.load(path).analyses.stability == Stability()  # every setting at its default


@pytest.mark.parametrize("text", ["  statics:\n", "  statics: {}\n", "  stability:\n  statics:\n"])
def test_an_empty_analysis_key_without_defaults_names_what_it_needs(tmp_path, capsys, text):
    path = scene_with(tmp_path, "pump_pe600_dynamics", text)
    err = one_line(capsys, 2, "check", str(path))
    assert err.endswith("analyses.statics: given without settings; it needs discharge_ratio (docs/schema.md)"), err


# ---- the ross extra ----------------------------------------------------------------------------------------------
def test_list_and_check_name_the_extra_a_scene_needs(capsys):
    assert cli.main(["list"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    needs = {name for name, line in lines.items() if "(needs the ross extra" in line}
    assert needs == {"spinup_ross_rotor", "ross_spinup_robust", "ross_spinup_time_optimal"}
    assert cli.main(["check", "ross_spinup_robust"]) == 0
    assert "valid; analyses: ross_spinup_robust (needs the ross extra" in capsys.readouterr().out


def test_without_the_extra_check_says_so_and_run_exits_2_naming_the_install(capsys, monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "ross", None)  # as if not installed: its import fails
    assert cli.main(["check", "spinup_ross_rotor"]) == 0
    assert ("valid; analyses: ross_spinup (needs the ross extra: pip install 'autobal[ross]', not installed)"
            in capsys.readouterr().out)
    err = one_line(capsys, 2, "run", "spinup_ross_rotor", "--out", str(tmp_path / "out"))
    assert err == ("autobal: bad input: spinup_ross_rotor: its analyses need the ross extra, which is not installed: "
                   "pip install 'autobal[ross]'")
    assert list(tmp_path.iterdir()) == []  # refused before anything was written


# ---- output folders and report.html follow the umask ------------------------------------------------------------
@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "out"
    assert cli.main(["run", FAST, "--out", str(out), "-q"]) == 0
    return out


def copied(run_folder: Path, out: Path, but: str = "") -> Path:
    """A copy of the files of ``run_folder`` (but the one named ``but``) in a new folder ``out``."""
    out.mkdir()
    for f in run_folder.iterdir():
        if f.name != but:
            (out / f.name).write_bytes(f.read_bytes())
    return out


@pytest.mark.parametrize("mask", [0o022, 0o027, 0o002])
def test_output_folder_and_report_follow_the_umask(tmp_path, capsys, mask, run_folder):
    from autobal.output import OutputFolder

    old = os.umask(mask)
    try:
        folder = OutputFolder(tmp_path / "out")
        assert folder.tmp.stat().st_mode & 0o777 == 0o777 & ~mask  # as mkdir makes it (mkdtemp's is 0o700)
        assert folder.commit().stat().st_mode & 0o777 == 0o777 & ~mask
        out = copied(run_folder, tmp_path / "copy")
        assert cli.main(["report", str(out)]) == 0
        assert (out / "report.html").stat().st_mode & 0o777 == 0o666 & ~mask  # as open() makes a file
    finally:
        os.umask(old)


# ---- autobal report writes only regular files inside its folder --------------------------------------------------
def test_report_replaces_a_symlinked_report_html_itself_and_never_writes_through_it(run_folder, tmp_path, capsys):
    out = copied(run_folder, tmp_path / "out", but="report.html")
    outside = tmp_path / "precious.txt"
    outside.write_text("not yours\n")
    (out / "report.html").symlink_to(outside)
    assert cli.main(["report", str(out)]) == 0
    assert outside.read_text() == "not yours\n"  # the file the link pointed to is left as it was
    page = out / "report.html"
    assert not page.is_symlink() and page.is_file() and "<html" in page.read_text()
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in run_folder.iterdir())  # no temp file


def test_report_html_that_is_a_folder_is_one_line_and_leaves_no_temp_file(run_folder, tmp_path, capsys):
    out = copied(run_folder, tmp_path / "out", but="report.html")
    (out / "report.html").mkdir()
    err = one_line(capsys, 2, "report", str(out))
    assert "report.html: cannot be written" in err
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


# ---- a data file that is not a table: refused without quoting it ------------------------------------------------
@pytest.mark.parametrize("content", ["root:x:0:0:root:/root:/bin/bash\nsecret,line\n",
                                     "password = hunter2 [admin]x\n1,2\n"])
def test_a_data_file_that_is_not_a_table_is_refused_without_quoting_it(tmp_path, capsys, content):
    data = tmp_path / "notes.txt"
    data.write_text(content)
    err = one_line(capsys, 2, "check", "rig_table43_fit", "--set", f"analyses.estimation.data={data}")
    assert "not a data table: line 1 is no header of 'quantity [unit]' cells" in err
    for word in ("x:0:0", "bash", "secret", "hunter2", "admin"):  # (the temporary folder's path holds 'root')
        assert word not in err


@pytest.mark.skipif(not Path("/etc/passwd").is_file(), reason="no /etc/passwd")
def test_etc_passwd_as_data_is_refused_without_its_first_line(capsys):
    first = Path("/etc/passwd").read_text().splitlines()[0]
    err = one_line(capsys, 2, "check", "rig_table43_fit", "--set", "analyses.estimation.data=/etc/passwd")
    assert "not a data table" in err and first.split(":")[0] not in err.replace("/etc/passwd", "")


# ---- check runs every validation of run ---------------------------------------------------------------------------
def test_check_refuses_design_bounds_with_lower_above_upper(tmp_path, capsys):
    bounds = "cavity_volume: {lower: 1e-6 m^3, upper: 1e-3 m^3}"
    path = scene_with(tmp_path, "pump_pe600_design", replace=((bounds, "cavity_volume: {lower: 1e-3 m^3, "
                                                                        "upper: 1e-6 m^3}"),))
    err = one_line(capsys, 2, "check", str(path))
    assert err.endswith("analyses.design: variables.device.dynamics.cavity_volume: upper must exceed lower"), err
    path = scene_with(tmp_path, "pump_pe600_design", replace=((bounds, "cavity_volume: {lower: 1 kg, "
                                                                        "upper: 1e-3 m^3}"),))
    assert "variables.device.dynamics.cavity_volume: '1 kg' is not a volume" in one_line(capsys, 2, "check",
                                                                                          str(path))


def test_check_refuses_a_misspelt_monte_carlo_afc_parameter(capsys):
    err = one_line(capsys, 2, "check", "pump_pe600_montecarlo", "--set",
                   "analyses.montecarlo.afc.parameters={m_pp: {distribution: normal, cv: 0.05}}")
    assert "analyses.montecarlo.afc: parameters.m_pp: not a parameter of the nonlinear model; expected one of " \
           "m_p, k_pr" in err


# ---- a failed transient case has no numbers -----------------------------------------------------------------------
def test_a_transient_case_failed_at_t0_reports_null_not_zero(tmp_path, capsys):
    """A harmonic input at 1e6 rad/s on a 5 ms output spacing: CVODES exhausts its 20,000 steps before the first
    output (CV_TOO_MUCH_WORK at t = 0); the case has no response, so no max |dz|, no final dz, no accuracy."""
    path = scene_with(tmp_path, "pump_pe600_dynamics", "  transient:\n    duration: 50 ms\n    points: 11\n"
                      "    cases:\n      - {input: pressure_harmonic, amplitude: 0.5, frequency: 1e6 rad/s}\n")
    out = tmp_path / "out"
    assert cli.main(["run", str(path), "--out", str(out), "-q"]) == 3
    assert "CV_TOO_MUCH_WORK" in capsys.readouterr().err
    res = json.loads((out / "results.json").read_text())
    assert res["status"] == "failed"
    case = res["transient"]["cases"][0]
    assert case["failure"]["t"] == 0.0
    for key in ("max_dz", "final_dz"):
        assert case[key] is None and "integrator failed at t = 0 s" in case[f"{key}_status"]
    acc = res["transient"]["accuracy"]
    assert acc["estimate"] is None and acc["how"].startswith("none: the integrator failed")
    assert all(acc["cases"][0][k] is None and acc["cases"][0][f"{k}_status"] for k in ("curve", "max_dz", "final_dz"))


# ---- YAML anchors and merge keys -------------------------------------------------------------------------------
def test_a_block_shared_by_a_merge_key_is_read_as_written_out(tmp_path):
    inner = "inner_seal: {diameter: 145 mm, length: 190 mm, clearance: 0.35 mm}"
    outer = "outer_seal: {diameter: 140 mm, length: 260 mm, clearance: 0.35 mm, local_loss: 1.5, friction: 0.06}"
    path = scene_with(tmp_path, FAST, replace=(
        (inner, "inner_seal: &seal {diameter: 145 mm, length: 190 mm, clearance: 0.35 mm}"),
        (outer, "outer_seal: {<<: *seal, diameter: 140 mm, length: 260 mm, local_loss: 1.5, friction: 0.06}")))
    merged, shipped = scenario.load(path), scenario.load(FAST)
    assert merged.device.disc.outer_seal == shipped.device.disc.outer_seal
    assert merged.model_dump() == shipped.model_dump()


@pytest.mark.parametrize("text, words", [
    ("a: &s {x: 1}\nb: {<<: *s, y: 2, y: 3}\n", "duplicate key 'y' at line 2"),  # still refused in one mapping
    ("b: !!python/object/apply:os.system ['true']\n", "not valid YAML"),  # no code, no custom tags
    ("b: {<<: 5}\n", "not valid YAML"),  # a merge of a scalar
])
def test_merge_keys_keep_the_loader_safe(tmp_path, text, words):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(scenario.ScenarioError, match=re.escape(words)):
        scenario.read(path)


# ---- an unreachable drive is refused before solving ------------------------------------------------------------
def test_an_unreachable_jeffcott_drive_is_refused_before_solving(capsys):
    """The datasheet rotor (J = 2 kg m^2 with the unbalance's m e^2) with 50 N m instead of 150: alpha <= 25 rad/s^2
    below the 45 kW power limit (45 kW / (2 x 418.9 rad/s) = 53.7 rad/s^2 at the top), so 62.83 -> 418.88 rad/s
    takes 356.05 x 2 / 50 = 14.24 s, after the 8 s deadline; 1e-3 N m: 7.1e5 s."""
    err = refused(capsys, "spinup_rotor_datasheet", "rotor.drive.max_torque=50 N*m")
    assert "analyses.spinup: the drive's torque, power and motor limits on its inertia 2 kg m^2 and |alpha| <= " \
           "60 rad/s^2 take it from 62.83 to 418.9 rad/s in 14.24 s at the earliest, after the horizon 8 s" in err
    assert "7.121e+05 s at the earliest" in refused(capsys, "spinup_rotor_datasheet", "rotor.drive.max_torque=1e-3 N*m")


def test_an_acceleration_limit_that_cannot_reach_the_final_speed_is_refused_by_check_and_run(capsys):
    """40 -> 210 rad/s at |alpha| <= 40 rad/s^2 takes 170/40 = 4.25 s: a 0.5 s deadline is refused with that reason,
    by ``autobal check`` as by ``autobal run`` (before, the run solved and reported a violated deflection limit)."""
    why = "analyses.spinup: the acceleration limit |alpha| <= 40 rad/s^2 takes it from 40 to 210 rad/s in 4.25 s " \
          "at the earliest, after the horizon 0.5 s"
    assert why in refused(capsys, "spinup_jeffcott_deadline_5s", "analyses.spinup.horizon=0.5 s")
    assert cli.main(["check", "spinup_jeffcott_deadline_5s", "--set", "analyses.spinup.horizon=0.5 s"]) == 2
    assert why in capsys.readouterr().err
    assert cli.main(["check", "spinup_rotor_datasheet", "--set", "rotor.drive.max_torque=50 N*m"]) == 2
    assert "14.24 s at the earliest, after the horizon 8 s" in capsys.readouterr().err
    assert cli.main(["check", "spinup_jeffcott_deadline_5s", "--set", "analyses.spinup.horizon=4.25 s"]) == 0
    assert "posed without solving: spinup" in capsys.readouterr().out


def test_a_deadline_the_drive_just_keeps_is_not_refused():
    """A motor whose no-load speed is 1.01 x the final speed: 1/alpha is steep and convex near the top, where
    trapezoids overestimated the earliest arrival by 0.1 %.  The deadline at the exact earliest arrival (quad) is
    posed; 0.1 % before it is refused, with a lower bound of the arrival within 1e-3 of the exact one (4 digits)."""
    from scipy.integrate import quad

    from autobal.ocp.simulation import drive_unreachable, rate_cap
    from tests.test_spinup_derivatives import DRIVE

    kw = {"motor_stall_torque": 0.2, "motor_no_load_speed": 1.01 * 210.0}
    probe = S.SpinupOcp(DRIVE, 40.0, 210.0, 100.0, 1e4, **kw)
    exact = quad(lambda w: 1.0 / rate_cap(probe, w), 40.0, 210.0, limit=200, epsabs=0, epsrel=1e-12)[0]
    assert drive_unreachable(S.SpinupOcp(DRIVE, 40.0, 210.0, exact, 1e4, **kw)) is None
    why = drive_unreachable(S.SpinupOcp(DRIVE, 40.0, 210.0, 0.999 * exact, 1e4, **kw))
    bound = float(why.split(" s at the earliest")[0].rsplit(" ", 1)[1])
    assert exact * (1 - 1e-3) < bound <= exact


def test_an_unreachable_modal_drive_is_refused_when_posed():
    """The one-disk modal rotor (tests/test_ross_rotor.py) with J = I_p + 0.05 = 0.13 kg m^2 on a 100 W drive: power
    limited from the start (100/(0.13 x 50) = 15.4 < 100 rad/s^2), the earliest arrival J (w_f^2 - w_0^2)/(2P) =
    0.13 x 20000 / 200 = 13 s; a motor whose no-load speed is below the final speed never gets there."""
    import dataclasses

    from autobal.models import ross_rotor as rr
    from autobal.ocp.modal import ModalSpinupOcp
    from tests.test_ross_rotor import Ip, disk_rotor

    red = dataclasses.replace(rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5),
                              polar_inertia=Ip)
    kw = {"settling_time": 0.3, "intervals": 30, "drive_inertia": 0.05}
    with pytest.raises(ValueError, match=r"from 50 to 150 rad/s in 13 s at the earliest, after the horizon 1.5 s"):
        ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), power_max=100.0, **kw)
    with pytest.raises(ValueError, match=r"no further than 120 rad/s: it never reaches the final speed 150 rad/s"):
        ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), motor_stall_torque=50.0, motor_no_load_speed=120.0, **kw)
    ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), power_max=3000.0, **kw)  # 0.13 x 20000 / 6000 = 0.43 s: posed


# ---- the ROSS spin-up predicts its run time --------------------------------------------------------------------
def test_the_ross_spinup_predicts_its_run_time_and_says_it_is_long():
    """The shipped scene takes about 90 s (ROSS's import and critical speeds, the search, the NLP solves): the estimate
    is within a factor of 1.5 of it, and above LONG_RUN_S the run says so first; without the comparison with ROSS
    the critical speeds' share goes."""
    scn = scenario.load("spinup_ross_rotor")
    est = analyses.estimate_seconds(scn)["ross_spinup"]
    assert 60 < est < 135
    assert analyses.long_run_note(scn).startswith("this run is estimated to take about 1.5 min")
    scn = scenario.load("spinup_ross_rotor", {"analyses.ross_spinup.validate_with_ross": False})
    assert analyses.estimate_seconds(scn)["ross_spinup"] == pytest.approx(est - analyses.COST["ross_critical_speeds"])


# ---- Ctrl-C and SIGTERM within 2 s in the ROSS spin-up (tests/test_interrupt.py's run) --------------------------
def _assert_stopped(code, lines, out, seconds, sig):
    assert code == 128 + sig, lines
    assert lines == [f"autobal: interrupted ({signal.Signals(sig).name})"], lines
    assert json.loads((out / "interrupted.json").read_text())["status"] == "interrupted"
    assert sorted(p.name for p in out.parent.iterdir() if p.name != "trace.txt") == ["out"]  # no .out.*.tmp beside
    assert seconds < 2.0, f"took {seconds:.1f} s to stop"


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_and_sigterm_stop_the_ross_computations_within_2_s(tmp_path, sig):
    """ROSS's numba compiles dropped a Ctrl-C and its critical speeds ran on for a minute: now in a child process
    (interrupt.isolated) that the interrupt kills."""
    _assert_stopped(*interrupted_run(tmp_path, "spinup_ross_rotor", "_ross_side", sig, 1.0), sig)


@pytest.mark.slow
def test_ctrl_c_stops_the_modal_nlp_solve_within_2_s(tmp_path):
    _assert_stopped(*interrupted_run(tmp_path, "spinup_ross_rotor", "spinup", signal.SIGINT, 0.5,
                                     ["--set", "analyses.ross_spinup.validate_with_ross=false"]), signal.SIGINT)


@pytest.mark.slow
def test_an_unreachable_ross_drive_is_refused_before_solving(capsys):
    """1e-3 N m on the shipped rotor (its polar inertia from ROSS): refused once the rotor is reduced, no solve."""
    err = refused(capsys, "spinup_ross_rotor", "ross_rotor.drive.max_torque=1e-3 N*m")
    assert "analyses.ross_spinup: the drive's torque, power and motor limits on its inertia" in err
    assert "at the earliest, after the horizon 4 s" in err
    # autobal check poses it as the run does: refused there too, and a drive it can keep is accepted
    assert cli.main(["check", "spinup_ross_rotor", "--set", "ross_rotor.drive.max_torque=1e-3 N*m"]) == 2
    assert "at the earliest, after the horizon 4 s" in capsys.readouterr().err
    assert cli.main(["check", "spinup_ross_rotor", "--set", "ross_rotor.drive.max_deceleration=0 rad/s^2"]) == 0
    assert "posed without solving: ross_spinup" in capsys.readouterr().out


def test_isolated_with_a_hash_seed_runs_a_fresh_interpreter_with_that_seed():
    """hash_seed: the child's string hashes are those of PYTHONHASHSEED=seed (a fresh interpreter), the same on every
    call, whatever this process's seed; its exceptions come back as without one."""
    from autobal.analysis.run import interrupt
    from autobal.errors import ScenarioError

    expected = subprocess.run([sys.executable, "-c", "print(hash('autobal'))"], capture_output=True, text=True,
                              env=os.environ | {"PYTHONHASHSEED": "0"}, check=True).stdout.strip()
    assert [interrupt.isolated(hash, "autobal", hash_seed=0) for _ in range(2)] == [int(expected)] * 2
    with pytest.raises(ScenarioError, match="no-such-scene"):
        interrupt.isolated(scenario.resolve, "no-such-scene", hash_seed=0)


@pytest.mark.slow
@pytest.mark.extra("ross")
def test_the_ross_rotor_is_the_same_whatever_the_hash_seed(tmp_path):
    """ROSS sums its element matrices over a set: under two hash seeds of the calling process the lateral matrices
    handed back are bit-identical (they differed in M, G and K_sdt before the child got a fixed seed)."""
    code = ("import hashlib, numpy as np, autobal\n"
            "from autobal.analyses.ross_spinup import ross_side\n"
            "from autobal.parts.ross_rotor import adapt\n"
            "lat, _ = ross_side(adapt(autobal.load('spinup_ross_rotor').ross_rotor)[0])\n"
            "print('digest', hashlib.sha1(b''.join(np.ascontiguousarray(getattr(lat, k)).tobytes() "
            "for k in ('M', 'K', 'C', 'G', 'Ksdt'))).hexdigest())\n")
    digests = [next(line for line in subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, check=True,
        env=os.environ | {"PYTHONHASHSEED": seed}).stdout.splitlines() if line.startswith("digest")) for seed in "12"]
    assert digests[0] == digests[1]


def test_isolated_returns_raises_and_is_ended_by_an_interrupt():
    """interrupt.isolated: the child's answer, its ScenarioError raised again here, and a signal during the wait
    raises at once and kills the child (which ignores SIGINT and SIGTERM itself)."""
    from autobal.analysis.run import interrupt
    from autobal.errors import Interrupted, ScenarioError

    assert interrupt.isolated(pow, 3, 4) == 81
    with pytest.raises(ScenarioError, match="no such"):
        interrupt.isolated(scenario.resolve, "no-such-scene")

    def alarm(signum, frame):
        raise Interrupted(signal.SIGINT)

    previous = signal.signal(signal.SIGALRM, alarm)
    t0 = time.monotonic()
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.3)
        with pytest.raises(Interrupted):
            interrupt.isolated(time.sleep, 30.0)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.monotonic() - t0 < 2.0  # not the 30 s of the child, which was killed
