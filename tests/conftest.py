import pytest

from autobal import scenario
from autobal.analysis.statics import StaticsSolver
from autobal.models.device import design


@pytest.fixture(scope="session")
def pump():
    return StaticsSolver(design(scenario.load("pump_pe600_statics").device))


@pytest.fixture(scope="session")
def compressor():
    return StaticsSolver(design(scenario.load("compressor_k180_statics").device))
