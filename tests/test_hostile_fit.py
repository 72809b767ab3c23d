"""Hostile input to the estimation through the command line: data paths that name no data file,
data that do not identify the fits, and more work than the schema allows.  Every case exits 2
with one line on stderr naming the fault, within seconds (a subprocess with a time limit guards
against a hang)."""

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from autobal import cli
from autobal.models.hydroheel import TurbulentDisc

pytestmark = pytest.mark.cli
FITS = [{"name": "a", "parameters": {"alpha": {"value": 1.75}, "tau_max": {"value": 2.75}}}]


def _scene(folder: Path, data: str, **estimation) -> Path:
    p = folder / "scene.yaml"
    p.write_text(yaml.safe_dump({"name": "fit", "title": "t", "analyses": {
        "estimation": {"data": data, "fits": FITS} | estimation}}))
    return p


def _one_line(capsys, code: int, *args) -> str:
    assert cli.main(list(args)) == code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("data, message", [
    ("/proc/self/mem", "a system file (proc), not a data file"),
    ("/proc/self/environ", "a system file (proc), not a data file"),
    ("/dev/zero", "not a regular file"),
    ("/", "is a folder, not a data file"),
])
def test_system_files_refused(tmp_path, capsys, data, message):
    assert message in _one_line(capsys, 2, "check", str(_scene(tmp_path, data)))


def test_fifo_refused_without_blocking(tmp_path, capsys):
    """A FIFO with no writer would block a reader for ever: refused by its type before it is opened."""
    os.mkfifo(tmp_path / "pipe.csv")
    assert "not a regular file (a device, FIFO or socket)" in _one_line(capsys, 2, "check",
                                                                        str(_scene(tmp_path, "pipe.csv")))


def test_symlink_to_a_system_file_refused(tmp_path, capsys):
    (tmp_path / "d.csv").symlink_to("/proc/self/mem")
    assert "a system file (proc)" in _one_line(capsys, 2, "check", str(_scene(tmp_path, "d.csv")))


@pytest.mark.parametrize("content, message", [
    (b"\x00\x01tau [1]", "a binary file, not a CSV text"),
    ("tau [1],u [1]\n1,0.5\n".encode("utf-16"), "a binary file, not a CSV text"),
    (b"tau [1],u [1]\n1,\xe9\n", "not UTF-8 text (byte 0xe9 at offset 16)"),
    (b"tau [1];u [1]\n1;0,5\n1;0.5.1\n", "line 3, column 'u [1]': '0.5.1' is not a number"),
])
def test_unreadable_text_refused(tmp_path, capsys, content, message):
    (tmp_path / "d.csv").write_bytes(content)
    assert message in _one_line(capsys, 2, "check", str(_scene(tmp_path, "d.csv")))


def test_a_header_cell_is_not_echoed_at_length(tmp_path, capsys):
    (tmp_path / "d.csv").write_text("x" * 10_000 + ",u [1]\n1,1\n")
    err = _one_line(capsys, 2, "check", str(_scene(tmp_path, "d.csv")))
    assert "must read 'quantity [unit]'" in err and len(err) < 600


def _run_guarded(args: list[str], cwd: Path, limit_s: float = 60.0) -> tuple[subprocess.CompletedProcess, float]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "autobal", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=limit_s, check=False)
    return proc, time.perf_counter() - t0


def test_identical_rows_refused_at_once(tmp_path):
    """Every row the same (IPOPT ran to its iteration limit on these before): exit 2, one line, no
    solve."""
    (tmp_path / "d.csv").write_text("tau [1],u [1]\n" + "1.0,0.8\n" * 50)
    proc, _ = _run_guarded(["run", str(_scene(tmp_path, "d.csv")), "--out", str(tmp_path / "out")], tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "the data do not identify 2 free parameters: every row has the same load" in proc.stderr


def test_100000_rows_with_a_2000_sample_bootstrap_refused_at_once(tmp_path):
    """100,000 rows with 2000 bootstrap data sets (200 million residuals, about 5 GB held at once):
    refused by the schema's bound with the largest number of samples that fits it."""
    tau = np.linspace(0.5, 2.0, 100_000)
    u = TurbulentDisc(1.66, 2.75).gap(tau)
    np.savetxt(tmp_path / "d.csv", np.column_stack([tau, u]), delimiter=",", header="tau [1],u [1]", comments="")
    scene = _scene(tmp_path, "d.csv", bootstrap={"samples": 2000})
    proc, _ = _run_guarded(["run", str(scene), "--out", str(tmp_path / "out")], tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "bootstrap.samples: 2000 data sets of 100000 rows exceed 2,000,000 rows in all; use at most 20" \
        in proc.stderr
