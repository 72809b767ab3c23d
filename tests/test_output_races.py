"""Runs into one output folder at the same time end with exactly one run's files and nothing beside it.

autobal/output.py commits without a lock: each run writes its own temporary folder, and the last to
commit replaces the folder (moving the one there aside and removing it, retrying when another run got
there first).
"""

import json
import subprocess
import sys
import time

import pytest

from autobal.output import LOG, OutputFolder

FAST = "pump_pe600_statics"


def test_interleaved_commits_leave_the_last_one(tmp_path):
    """Three folders made before any commits (as three runs started together): the last commit wins, each
    commit of a folder another run has just filled moves that aside and removes it."""
    out = tmp_path / "out"
    folders = [OutputFolder(out) for _ in range(3)]
    for i, folder in enumerate(folders):
        (folder.tmp / LOG).touch()
        (folder.tmp / "run.txt").write_text(str(i))
    for i, folder in enumerate(folders):
        folder.commit()
        assert (out / "run.txt").read_text() == str(i)
        waiting = {f.tmp.name for f in folders[i + 1:]}
        assert {p.name for p in tmp_path.iterdir()} == {"out", *waiting}  # nothing moved aside is left
    assert (out / "run.txt").read_text() == "2"
    assert sorted(p.name for p in out.iterdir()) == [LOG, "run.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


@pytest.mark.slow
@pytest.mark.cli
def test_concurrent_runs_into_one_folder(tmp_path):
    """Four ``autobal run`` processes into one --out at once: every one succeeds; the folder holds the
    files of exactly one of them (results.json, report.html and the files it lists agree) and nothing
    else is left beside it."""
    n = 4
    out = tmp_path / "shared"
    procs = [subprocess.Popen([sys.executable, "-m", "autobal", "run", FAST, "--out", str(out), "-q",
                               "--set", f"title=concurrent run {i}"], cwd=tmp_path,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for i in range(n)]
    t0 = time.monotonic()
    errors = [p.communicate(timeout=600)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * n, errors
    assert time.monotonic() - t0 < 600
    assert [p.name for p in tmp_path.iterdir()] == ["shared"]  # no .shared.*.tmp or .tmp.old beside it
    results = json.loads((out / "results.json").read_text())
    title = results["title"]
    assert title.startswith("concurrent run ")
    page = (out / "report.html").read_text()
    assert [i for i in range(n) if f"concurrent run {i}" in page] == [int(title.split()[-1])]
    assert results["meta"]["overrides"] == {"title": title}
    assert sorted(p.name for p in out.iterdir()) == sorted({*results["files"], "results.json", LOG})
