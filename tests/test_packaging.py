"""The wheel built from the repository holds every shipped scene and runs one from another folder."""

import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.cli

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_holds_the_scenes_and_runs_one(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path / "dist"), str(ROOT)],
                   check=True, capture_output=True)
    wheel = next((tmp_path / "dist").glob("autobal-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = {f"autobal/scenarios/{p.relative_to(ROOT / 'scenarios')}" for p in (ROOT / "scenarios").rglob("*")
               if p.is_file() and p.suffix in (".yaml", ".csv")}
    assert len(shipped) > 20 and shipped <= names
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(site), str(wheel)],
                   check=True, capture_output=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    code = ("import autobal, autobal.cli, sys; assert autobal.__file__.startswith(sys.argv[1]), autobal.__file__; "
            "sys.exit(autobal.cli.main(['run', 'pump_pe600_statics', '--quiet', '--out', 'o']))")
    env = os.environ | {"PYTHONPATH": str(site)}
    subprocess.run([sys.executable, "-c", code, str(site)], cwd=work, env=env, check=True)
    res = json.loads((work / "o" / "results.json").read_text())
    assert res["statics"]["exact"]["psi2_0"] == pytest.approx(1.0202057, abs=1e-7)  # Pavlenko (2014), App. A


@pytest.mark.slow
def test_the_readme_test_command_collects_with_only_the_test_extra(tmp_path):
    """The README's test command installs ``.[test]`` alone: in a fresh environment with no other extra, the
    default set collects without an error (a test that needs an extra is marked ``extra`` and skips)."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = str(venv / "bin" / "python")
    subprocess.run([python, "-m", "pip", "install", "-q", "-e", f"{ROOT}[test]"], check=True, capture_output=True)
    absent = subprocess.run([python, "-c", "import importlib.util as u; print([m for m in ('ross', 'mkdocs', 'pandas', "
                             "'bokeh') if u.find_spec(m)])"], check=True, capture_output=True, text=True)
    assert absent.stdout.strip() == "[]"
    out = subprocess.run([python, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"], cwd=ROOT,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    assert "ERROR" not in out.stdout
    collected = sum(int(n) for n in re.findall(r"^tests/\S+: (\d+)$", out.stdout, re.M))
    assert collected > 1000, out.stdout[-2000:]
