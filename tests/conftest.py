import importlib.util
import inspect
import re

import pytest

from autobal import api, scenario
from autobal.analysis.numerics.statics import StaticsSolver
from autobal.parts.device import design


@pytest.fixture(scope="session")
def pump():
    return StaticsSolver(design(scenario.load("pump_pe600_statics").device))


@pytest.fixture(scope="session")
def compressor():
    return StaticsSolver(design(scenario.load("compressor_k180_statics").device))


def _edit(data: dict, path: str, value) -> dict:
    """A deep copy of a scene with the key at the dotted ``path`` set to ``value`` (deleted if None)."""
    import copy

    out = copy.deepcopy(data)
    *parents, last = path.split(".")
    node = out
    for k in parents:
        node = node[k]
    if value is None:
        del node[last]
    else:
        node[last] = value
    return out


@pytest.fixture
def scene_edit():
    """``scene_edit(data, "a.b.c", value)``: a copy of a scene dict with one key changed or removed."""
    return _edit


#: optional extra of pyproject.toml -> the module it installs: a test marked ``@pytest.mark.extra("ross")`` skips
#: without it.  The README's test command installs only ``.[test]``; .ci/run then installs the extras and runs
#: ``pytest -m "extra and not slow"`` (and the slow set), so every such test runs in CI.
EXTRAS = {"ross": "ross", "docs": "mkdocs", "notebook": "pandas", "explore": "bokeh"}


def pytest_runtest_setup(item):
    for mark in item.iter_markers("extra"):
        (extra,) = mark.args
        if importlib.util.find_spec(EXTRAS[extra]) is None:
            pytest.skip(f"needs the '{extra}' extra: pip install -e '.[{extra}]'")


_SHIPPED_RUNS: dict = {}


@pytest.fixture(scope="session")
def shipped_run(tmp_path_factory):
    """``shipped_run(name) -> (Run, folder)``: one run of a shipped scene, saved to a folder, shared by every
    test of the session that needs that scene (the report, the null check, the scene tests)."""

    def get(name: str):
        if name not in _SHIPPED_RUNS:
            folder = tmp_path_factory.mktemp("shipped") / name
            _SHIPPED_RUNS[name] = (api.run(name, out=folder), folder)
        return _SHIPPED_RUNS[name]

    return get


_SHIPPED_NAMES = {p.stem for p in scenario.shipped()}
_NAMED = re.compile(r"shipped_run\(\s*[\"'](\w+)[\"']")  # shipped_run("pump_pe600_statics") in a test's source


def _scene_of(item) -> str:
    """The shipped scene a test runs through shipped_run: its ``name`` or ``scene`` parameter if that is a shipped
    scene, else the one scene its source names in shipped_run("..."); "shipped" when there are several or none."""
    params = getattr(getattr(item, "callspec", None), "params", {})
    named = {v for k, v in params.items() if k in ("name", "scene") and v in _SHIPPED_NAMES}
    if not named:
        named = set(_NAMED.findall(inspect.getsource(item.function))) & _SHIPPED_NAMES
    return named.pop() if len(named) == 1 else "shipped"


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups into the node ids
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``-n 2``, README and .ci/run; ``--dist loadgroup`` is in the addopts) the tests of one
    shipped scene go to one worker, so that the scene runs once (shipped_run shares a run within a worker only):
    each test that uses shipped_run is grouped by its scene (:func:`_scene_of`)."""
    for item in items:
        if "shipped_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group(_scene_of(item)))
