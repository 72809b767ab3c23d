"""Hostile conditions at the operating-system level and hostile text (issue #25, items 4-6).

Every case ends with its documented exit code (2 bad input or a file that cannot be read or written,
74 standard output not writable, 130 interrupt, 141 broken pipe), at most three lines on stderr, no
traceback, no terminal escape sequence, within a wall-time bound that guards against a hang, and
leaves nothing beside the output folder.  The OS-level cases (signals, pipes, /dev/full, a named pipe)
run the ``autobal`` command in a subprocess; the others call ``cli.main``.
"""

import base64
import errno
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autobal import cli

pytestmark = pytest.mark.cli

FAST = "pump_pe600_statics"  # about 1.3 s
WALL_S = 120.0  # hang guard on a loaded machine: every case ends far sooner
AUTOBAL = [sys.executable, "-m", "autobal"]


def sigint_default():
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # as on a terminal (a shell starts background jobs ignoring it)


def assert_clean(code: int, err: str, seconds: float, expected: int, contains: str = ""):
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("CasADi - ")]
    assert code == expected, err[-2000:]
    assert len(lines) <= 3, lines[:5]
    assert "Traceback" not in err and "Exception ignored" not in err, err[-2000:]
    assert not re.search(r"[\x00-\x09\x0b-\x1f\x7f-\x9f]", err), repr(err[-500:])  # no control character
    assert seconds < WALL_S
    assert contains in err, err[-2000:]


def command(args: list[str], cwd: Path, stdout=subprocess.DEVNULL, timeout: float = WALL_S):
    t0 = time.monotonic()
    proc = subprocess.run([*AUTOBAL, *args], cwd=cwd, stdout=stdout, stderr=subprocess.PIPE, text=True,
                          timeout=timeout, preexec_fn=sigint_default)
    return proc.returncode, proc.stderr, time.monotonic() - t0


def in_process(capsys, args: list[str]):
    t0 = time.monotonic()
    code = cli.main(args)
    return code, capsys.readouterr().err, time.monotonic() - t0


def beside(out: Path) -> list[str]:
    """What the folder holding ``out`` holds besides ``out`` (temporary or moved-aside folders)."""
    return sorted(p.name for p in out.parent.iterdir() if p.name != out.name)


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "out"
    assert cli.main(["run", FAST, "--out", str(out), "-q"]) == 0
    return out


@pytest.fixture
def copy_of_run(run_folder, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(run_folder, out)
    return out


# ---- autobal report on a damaged output folder: (case, damage to OUT, text of the one line) ----------------------
def _truncate(out):
    text = (out / "results.json").read_text()
    (out / "results.json").write_text(text[: len(text) // 2])


def _replace(data: bytes):
    def damage(out):
        (out / "results.json").write_bytes(data)
    return damage


def _folder(out):
    (out / "results.json").unlink()
    (out / "results.json").mkdir()


def _fifo(out):
    (out / "results.json").unlink()
    os.mkfifo(out / "results.json")


def _to_dev_zero(out):
    (out / "results.json").unlink()
    (out / "results.json").symlink_to("/dev/zero")


def _no_results(out):
    for p in out.iterdir():
        p.unlink()


DAMAGED = [
    ("truncated", _truncate, "not valid JSON"),
    ("json_list", _replace(b"[1, 2, 3]\n"), "a JSON list"),
    ("json_string", _replace(b'"ok"\n'), "a JSON str"),
    ("not_utf8", _replace(b'{"title": "\xff\xfe"}'), "not UTF-8"),
    ("nested_200000_deep", _replace(b"[" * 200_000 + b"]" * 200_000), "nested too deeply"),
    ("a_folder", _folder, "a folder"),
    ("named_pipe", _fifo, "not a regular file"),
    ("link_to_dev_zero", _to_dev_zero, "not a regular file"),
    ("nothing_to_show", _no_results, "holds neither results.json"),
]


@pytest.mark.parametrize("case, damage, text", DAMAGED, ids=[c[0] for c in DAMAGED])
def test_report_of_a_damaged_folder_is_one_line(copy_of_run, tmp_path, capsys, case, damage, text):
    page = (copy_of_run / "report.html").read_bytes()
    damage(copy_of_run)
    if case in ("named_pipe", "link_to_dev_zero"):  # in a subprocess, so that a hang is caught
        code, err, seconds = command(["report", str(copy_of_run)], tmp_path)
    else:
        code, err, seconds = in_process(capsys, ["report", str(copy_of_run)])
    assert_clean(code, err, seconds, 2, text)
    if case != "nothing_to_show":
        assert (copy_of_run / "report.html").read_bytes() == page  # not rewritten


def test_report_of_a_missing_a_file_and_a_too_long_folder(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    for folder, text in [(tmp_path / "missing", "No such file"), (tmp_path / "file", "not a folder"),
                         (tmp_path / ("d" * 300), "File name too long")]:
        assert_clean(*in_process(capsys, ["report", str(folder)]), 2, contains=text)


def test_report_into_a_folder_that_cannot_be_written(copy_of_run, capsys, monkeypatch):
    """A read-only folder (simulated: root may write anywhere): one line, exit 2."""
    import tempfile

    mkstemp = tempfile.mkstemp

    def refuse(*args, **kwargs):  # report.html is written to a temporary file in the folder first
        if Path(kwargs.get("dir") or ".") == copy_of_run:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(copy_of_run))
        return mkstemp(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    assert_clean(*in_process(capsys, ["report", str(copy_of_run)]), 2, contains="report.html: cannot be written")


def test_report_embeds_no_file_from_outside_its_folder(copy_of_run, tmp_path, capsys):
    """A tampered ``files`` list (../, an absolute path, a link out of the folder) embeds nothing from outside."""
    secret = tmp_path / "secret.png"
    secret.write_bytes(b"\x89PNG\r\n\x1a\n" + b"SECRET-BYTES-" * 50)
    (copy_of_run / "link.png").symlink_to(secret)
    results = json.loads((copy_of_run / "results.json").read_text())
    inside = [f for f in results["files"] if f.endswith(".png")]
    assert inside, "the run should have figures to embed"
    results["files"] = ["../secret.png", str(secret), "link.png", "../../" * 20 + str(secret), 7, None,
                        *results["files"]]
    (copy_of_run / "results.json").write_text(json.dumps(results))
    code, err, seconds = in_process(capsys, ["report", str(copy_of_run)])
    assert_clean(code, err, seconds, 0, "names 4 file(s) outside the folder")
    page = (copy_of_run / "report.html").read_text()
    assert base64.b64encode(secret.read_bytes()).decode() not in page
    assert "SECRET-BYTES" not in page
    assert page.count("data:image/png;base64,") == len(inside)  # the folder's own figures are still embedded


def test_report_reads_no_pipe_named_as_the_scene_file_and_survives_wrong_types(copy_of_run, tmp_path):
    """results.json's meta.file naming a named pipe is not read (no hang); wrong types where a list or a
    mapping belongs are skipped."""
    os.mkfifo(tmp_path / "scene.yaml")
    results = json.loads((copy_of_run / "results.json").read_text())
    results["meta"]["file"] = str(tmp_path / "scene.yaml")
    results["outputs"] = ["not", "a", "mapping"]
    (copy_of_run / "results.json").write_text(json.dumps(results))
    code, err, seconds = command(["report", str(copy_of_run)], tmp_path)
    assert_clean(code, err, seconds, 0)
    results["meta"], results["files"] = ["not a mapping"], {"not": "a list"}
    (copy_of_run / "results.json").write_text(json.dumps(results))
    code, err, seconds = command(["report", str(copy_of_run)], tmp_path)
    assert_clean(code, err, seconds, 0)
    assert "data:image/png;base64," in (copy_of_run / "report.html").read_text()


def test_html_of_a_tampered_title_holds_no_control_characters(copy_of_run, capsys):
    results = json.loads((copy_of_run / "results.json").read_text())
    results["title"] = "\x1b]0;PWNED\x07<script>alert(1)</script>" + "t" * 100_000
    results["meta"]["overrides"] = {"title": "\x1b[2Jcleared\x9b31m"}
    (copy_of_run / "results.json").write_text(json.dumps(results))
    assert cli.main(["report", str(copy_of_run)]) == 0
    page = (copy_of_run / "report.html").read_text()
    assert "\x1b" not in page and "\x07" not in page and "\x9b" not in page and "PWNED" not in page
    assert "<script>alert(1)" not in page
    assert "t" * 600 not in page  # cut


# ---- hostile text: escapes and sizes in keys, values and titles --------------------------------------------------
TEXT = [
    ("osc_in_unknown_key", ["--set", "device.disc.\x1b]0;PWNED\x07x=1"], "unknown key"),
    ("csi_clear_in_value", ["--set", "device.disc.face.base_gap=\x1b[2J\x1b[H0.15 mm"], "base_gap"),
    ("c1_csi_in_title", ["--set", "title=a\x9b31mred"], "title: control characters"),
    ("osc_in_source", ["--set", "source=\x1b]0;PWNED\x07"], "source: control characters"),
    ("newlines_in_key", ["--set", "device.a\nb\nc\nd\ne=1"], "unknown key"),
    ("key_of_200_kB", ["--set", "device." + "k" * 200_000 + "=1"], "unknown key"),
    ("title_of_100000_characters", ["--set", "title=" + "x" * 100_000], "title"),
    ("value_of_200_kB", ["--set", "device.disc.face.base_gap=" + "9" * 200_000 + " mm"], "base_gap"),
]


@pytest.mark.parametrize("case, extra, text", TEXT, ids=[c[0] for c in TEXT])
def test_text_from_inputs_reaches_the_terminal_clean_and_short(capsys, case, extra, text):
    code, err, seconds = in_process(capsys, ["check", FAST, *extra])
    assert_clean(code, err, seconds, 2, text)
    assert len(err) < 700, len(err)


def test_a_title_with_escapes_in_the_scene_file_is_refused_in_one_line(tmp_path, capsys):
    """A title is one line of text: a scene file whose title holds an 8-bit CSI, an OSC or a bell is
    refused before anything runs, and the message shows none of them."""
    from autobal import scenario

    scene = tmp_path / "scene.yaml"
    text = scenario.resolve(FAST).read_text().replace("title:", 'title: "a\\x9b31m\\e]0;PWNED\\a red" #', 1)
    scene.write_text(text)
    code, err, seconds = in_process(capsys, ["run", str(scene), "--out", str(tmp_path / "out")])
    assert_clean(code, err, seconds, 2, "title: control characters")
    assert "PWNED" not in err
    assert not (tmp_path / "out").exists()


# ---- bad options and names ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, text", [
    (["run", FAST, "--scheduler", "garbage"], "--scheduler garbage"),
    (["run", FAST, "--scheduler", "tcp://host:port"], "not a dask scheduler address"),
    (["run", FAST, "--scheduler", "\x1b[2Jtcp://x:1"], "not a dask scheduler address"),
    (["check", "f" * 300 + ".yaml"], "File name too long"),
    (["run", FAST, "--out", "d" * 300], "File name too long"),
    (["accuracy", FAST, "--out", "d" * 300], "File name too long"),
], ids=["scheduler_garbage", "scheduler_port_not_a_number", "scheduler_escape", "file_name_300",
        "out_folder_name_300", "accuracy_folder_name_300"])
def test_bad_option_or_name_is_one_line(tmp_path, capsys, monkeypatch, args, text):
    monkeypatch.chdir(tmp_path)
    assert_clean(*in_process(capsys, args), 2, contains=text)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_scheduler_addresses_of_dask_are_accepted():
    for address in ["tcp://localhost:8786", "tcp://10.0.0.5:8786", "tls://scheduler.example.org:8786",
                    "tcp://[::1]:8786", "inproc://192.168.1.2"]:
        assert cli.SCHEDULER.fullmatch(address), address
    for address in ["garbage", "localhost:8786", "tcp://", "tcp://a b:1", "tcp://x:99999999", "http://x:1"]:
        assert not cli.SCHEDULER.fullmatch(address), address


# ---- the operating system: pipes, /dev/full, a full disk ---------------------------------------------------------
@pytest.mark.parametrize("args", [["list"], ["run", FAST, "--out", "out"]], ids=["list", "run"])
def test_broken_pipe_ends_quietly_with_141(tmp_path, args):
    """``autobal ... | head -1``: the reader goes after one line; the command ends quietly (exit 141) and a
    run still writes its folder."""
    t0 = time.monotonic()
    proc = subprocess.Popen([*AUTOBAL, *args], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=sigint_default)
    assert proc.stdout.readline()
    proc.stdout.close()  # as head -1 does
    try:
        err = proc.stderr.read().decode()
        code = proc.wait(timeout=WALL_S)
    finally:
        proc.kill()
    assert_clean(code, err, time.monotonic() - t0, 141)
    assert err.strip() == ""
    if args[0] == "run":
        assert json.loads((tmp_path / "out" / "results.json").read_text())["status"] == "ok"


def test_stdout_to_dev_full_is_one_line(tmp_path):
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full")
    with open("/dev/full", "w") as full:
        code, err, seconds = command(["run", FAST, "--out", "out"], tmp_path, stdout=full)
    assert_clean(code, err, seconds, 74, "standard output cannot be written (No space left on device)")
    assert json.loads((tmp_path / "out" / "results.json").read_text())["status"] == "ok"  # the run is written


def test_full_disk_while_writing_leaves_the_previous_folder(run_folder, tmp_path, capsys, monkeypatch):
    """ENOSPC while the run writes its files (simulated in the writer): one line naming the folder, the
    previous folder as it was, no temporary folder beside it."""
    out = tmp_path / "out"
    shutil.copytree(run_folder, out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def full(path, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("autobal.api.write_json", full)
    code, err, seconds = in_process(capsys, ["run", FAST, "--out", str(out), "-q"])
    assert_clean(code, err, seconds, 2, f"output folder {out}: cannot be written (No space left on device)")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert beside(out) == []


# ---- signals -----------------------------------------------------------------------------------------------------
def start_run(cwd: Path, out: str = "out", env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([*AUTOBAL, "run", FAST, "--out", out], cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, preexec_fn=sigint_default, env=env)


def interrupt(proc: subprocess.Popen, times: int = 1) -> str:
    """Send SIGINT ``times`` times 20 ms apart; stderr once the process has ended."""
    for i in range(times):
        time.sleep(0.02 if i else 0)
        proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=WALL_S)[1]
    finally:
        proc.kill()


def _loaded(pid: int, library: str) -> bool:
    try:
        return library in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc to see the imports under way")
def test_ctrl_c_while_the_solvers_are_imported(tmp_path):
    """SIGINT while numpy/CasADi are being imported (seen in /proc/PID/maps): exit 130 and one line."""
    t0 = time.monotonic()
    proc = start_run(tmp_path)
    while not _loaded(proc.pid, "numpy") and proc.poll() is None and time.monotonic() - t0 < WALL_S:
        time.sleep(0.002)
    assert not _loaded(proc.pid, "casadi"), "too late: the imports were over"
    err = interrupt(proc)
    assert_clean(proc.returncode, err, time.monotonic() - t0, 130, "autobal: interrupted (SIGINT)")
    assert list(tmp_path.iterdir()) == []  # nothing written: the run had not started


def test_ctrl_c_a_tenth_of_a_second_after_start(tmp_path):
    proc = start_run(tmp_path)
    t0 = time.monotonic()
    time.sleep(0.1)
    err = interrupt(proc)
    if proc.returncode != 130 and not re.search(r"/autobal/[\w/]*\.py", err):  # no frame of autobal's
        pytest.skip("the signal came while Python itself was starting, before any code of autobal ran "
                    "(a loaded machine); test_ctrl_c_while_the_solvers_are_imported covers the imports")
    assert_clean(proc.returncode, err, time.monotonic() - t0, 130, "autobal: interrupted (SIGINT)")
    assert [p.name for p in tmp_path.iterdir() if p.name != "out"] == []


def test_double_ctrl_c_leaves_interrupted_json_and_nothing_beside(tmp_path):
    """Two SIGINTs 20 ms apart once the solver runs: exit 130, one line, OUT holds interrupted.json, no
    temporary folder beside it."""
    trace, out = tmp_path / "trace.txt", tmp_path / "out"
    proc = start_run(tmp_path, str(out), env=os.environ | {"AUTOBAL_SOLVER_TRACE": str(trace)})
    t0 = time.monotonic()
    while not trace.exists() and proc.poll() is None and time.monotonic() - t0 < WALL_S:
        time.sleep(0.01)
    assert proc.poll() is None, "the run ended before its solver was called"
    err = interrupt(proc, times=2)
    assert_clean(proc.returncode, err, time.monotonic() - t0, 130, "autobal: interrupted (SIGINT)")
    assert json.loads((out / "interrupted.json").read_text())["status"] == "interrupted"
    assert not (out / "results.json").exists()
    assert beside(out) == ["trace.txt"]


# ---- output folders: accuracy's own folder, symbolic links -------------------------------------------------------
def test_accuracy_never_removes_the_runs_files(run_folder, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copytree(run_folder, tmp_path / "out" / FAST)  # what `autobal run FAST` wrote
    run_files = sorted(p.name for p in (tmp_path / "out" / FAST).iterdir())
    assert cli.main(["accuracy", FAST, "-q"]) == 0
    assert sorted(p.name for p in (tmp_path / "out" / FAST).iterdir()) == run_files
    assert "results.json" in run_files
    acc = json.loads((tmp_path / "out" / f"{FAST}-accuracy" / "accuracy.json").read_text())
    assert acc["status"] == "ok" and acc["scenario"] == FAST
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [FAST, f"{FAST}-accuracy"]


def test_interrupted_accuracy_leaves_interrupted_json(tmp_path, capsys, monkeypatch):
    from autobal.analyses import statics
    from autobal.errors import Interrupted

    def interrupted(scene, settings):  # what SIGINT raises inside a study
        raise Interrupted(signal.SIGINT)

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(statics, "accuracy", interrupted)
    code, err, seconds = in_process(capsys, ["accuracy", FAST, "-q"])
    assert_clean(code, err, seconds, 130, "autobal: interrupted (SIGINT)")
    out = tmp_path / "out" / f"{FAST}-accuracy"
    data = json.loads((out / "interrupted.json").read_text())
    assert (data["status"], data["analysis"], data["completed"]) == ("interrupted", "statics", [])
    assert beside(out) == []


def test_symlinked_out_keeps_the_link_and_leaves_nothing_beside(run_folder, tmp_path, capsys):
    target, link = tmp_path / "target", tmp_path / "link"
    shutil.copytree(run_folder, target)  # an earlier run
    link.symlink_to(target)
    assert cli.main(["run", FAST, "--out", str(link), "-q", "--set", "title=through the link"]) == 0
    assert link.is_symlink() and link.resolve() == target.resolve()
    assert json.loads((target / "results.json").read_text())["title"] == "through the link"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "target"]
