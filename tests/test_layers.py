"""Layering: the import-linter contract of pyproject.toml holds (models <- analysis <- ocp <- front door),
no module imports a private name of another, and the package has no import cycle.

import-linter reads the package as installed; the ``package-dir`` mapping puts models/, analysis/ and
ocp/ outside autobal/, so the test lays out that installed tree as symbolic links first.
"""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]


@pytest.fixture(scope="module")
def installed_tree(tmp_path_factory) -> Path:
    """``<tmp>/autobal`` laid out like the installed package, as links into the repository."""
    site = tmp_path_factory.mktemp("site")
    pkg = site / "autobal"
    pkg.mkdir()
    for f in (ROOT / "autobal").iterdir():
        if f.name != "__pycache__":
            (pkg / f.name).symlink_to(f)
    for name, folder in PACKAGE_DIR.items():
        if name.count(".") == 1:
            (pkg / name.split(".")[1]).symlink_to(ROOT / folder)
    return site


def test_import_linter_contracts_hold(installed_tree):
    env = os.environ | {"PYTHONPATH": str(installed_tree)}
    lint = Path(sys.executable).with_name("lint-imports")
    out = subprocess.run([str(lint), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=installed_tree,
                         env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
    assert "Contracts: 3 kept, 0 broken" in out.stdout


def test_no_import_cycles(installed_tree):
    code = (
        "import grimp, json, sys\n"
        "g = grimp.build_graph('autobal', exclude_type_checking_imports=True, cache_dir=None)\n"
        "edges = {m: sorted(g.find_modules_directly_imported_by(m)) for m in g.modules}\n"
        "json.dump(edges, sys.stdout)\n"
    )
    env = os.environ | {"PYTHONPATH": str(installed_tree)}
    out = subprocess.run([sys.executable, "-c", code], cwd=installed_tree, env=env, capture_output=True, text=True,
                         check=True)
    import json

    edges = json.loads(out.stdout)
    # Tarjan's strongly connected components: a component of more than one module is a cycle
    index, low, stack, on, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in edges:
        if v not in index:
            visit(v)
    # imports for type checking only are left out; the package's __init__ imports nothing eagerly
    assert cycles == []


def _sources():
    yield from (ROOT / "autobal").rglob("*.py")  # the front door with its analyses/ and parts/
    for folder in (f for n, f in PACKAGE_DIR.items() if n.count(".") == 1):
        yield from (ROOT / folder).rglob("*.py")


def test_no_private_imports_across_modules():
    private = []
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("autobal"):
                private += [f"{path.relative_to(ROOT)}: {node.module}.{a.name}" for a in node.names
                            if a.name.startswith("_") and not a.name.startswith("__")]
    assert private == []


def test_a_statics_run_imports_no_heavy_optional_package():
    # the CLI, a scene load and the statics study's modules leave out what only other analyses need
    # (the start-up goal of `autobal run pump_pe600_statics`, docs/benchmarks.md): scipy's optimize,
    # stats and special (work-precision peers, fits, the disc-loss model), python-control (dynamics)
    code = (
        "import sys\n"
        "import autobal.cli\n"
        "from autobal import scenario\n"
        "from autobal.analysis.numerics import statics\n"
        "from autobal.analysis.studies import statics_study, workprecision\n"
        "scenario.load('pump_pe600_statics')\n"
        "heavy = ('scipy.optimize', 'scipy.stats', 'scipy.special', 'scipy.linalg', 'control')\n"
        "print(' '.join(m for m in heavy if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == []


def _rooms(code: str) -> list[str]:
    """The analysis and part modules (autobal/analyses/<key>.py, autobal/parts/<part>.py) ``code`` imports."""
    code = "import sys\n" + code + ("print(' '.join(m for m in sorted(sys.modules) "
                                    "if m.startswith(('autobal.analyses.', 'autobal.parts.'))))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()


def test_a_scene_builds_only_the_schemas_it_names(tmp_path):
    # scenario.model_for imports the module of an analysis or a part only when the scene names it
    # (the start-up goal, docs/benchmarks.md): a statics run with its report imports the statics and the device ...
    argv = ["run", "pump_pe600_statics", "--quiet", "--out", str(tmp_path)]
    assert _rooms(f"from autobal import cli\nassert cli.main({argv!r}) == 0\n") == [
        "autobal.analyses.statics", "autobal.parts.derived", "autobal.parts.device"]
    assert (tmp_path / "report.html").is_file()
    # ... a dynamics scene its three analyses and the device with its dynamics schema, and the full Scenario
    # (the schema reference) every analysis and part of the registries
    assert _rooms("from autobal import scenario\nscenario.load('pump_pe600_dynamics')\n") == [
        "autobal.analyses.frequency", "autobal.analyses.stability", "autobal.analyses.transient",
        "autobal.parts.derived", "autobal.parts.device", "autobal.parts.device_dynamics"]
    from autobal import analyses, parts

    assert set(_rooms("from autobal import scenario\nscenario.Scenario\n")) == {
        *analyses.MODULES.values(), *parts.MODULES.values(), "autobal.parts.derived", "autobal.parts.device_dynamics"}


def test_the_slim_scene_models_validate_as_the_full_one():
    # cross-check: every shipped scene validates to the same values with the model built for it as with
    # Scenario, which holds every schema
    from autobal import scenario

    for path in scenario.shipped():
        data, ctx = scenario.read(path), {"folder": path.parent}  # the folder of the scene's data files
        slim = scenario.model_for(data)
        assert slim.model_validate(data, context=ctx).model_dump() == \
            scenario.Scenario.model_validate(data, context=ctx).model_dump(), path
    statics = scenario.read(scenario.resolve("pump_pe600_statics"))
    assert scenario.model_for(statics).model_fields["rotor"].annotation is type(None)
