import pytest

from autobal import api, scenario
from autobal.analysis.statics import StaticsSolver
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
