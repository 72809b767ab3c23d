"""The grouping under pytest-xdist (``-n 2``, with ``--dist loadgroup`` from the addopts) takes effect: tests of one
group run on one worker, so a shipped scene shared through ``shipped_run`` runs once (tests/conftest.py).  Under pytest
9.2 with pytest-xdist 3.8 the groups are silently ignored (pytest-xdist issue 1386): this test fails there."""

import subprocess
import sys

import pytest


@pytest.mark.cli
def test_loadgroup_puts_a_group_on_one_worker(tmp_path):
    (tmp_path / "conftest.py").write_text(
        "import pytest\n\n\n@pytest.hookimpl(tryfirst=True)\ndef pytest_collection_modifyitems(config, items):\n"
        "    for item in items:\n        item.add_marker(pytest.mark.xdist_group('scene'))\n")
    (tmp_path / "test_g.py").write_text("".join(f"def test_{i}():\n    pass\n\n\n" for i in range(6)))
    out = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadgroup", "-v", "-p",
                          "no:cacheprovider", "-o", "addopts=", str(tmp_path)], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300).stdout
    workers = {line.split("]")[0] for line in out.splitlines() if line.startswith("[gw") and "PASSED" in line}
    assert out.count("PASSED") == 6 and len(workers) == 1, out
