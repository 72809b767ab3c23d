"""One room per analysis (docs/contributing.md): every module of the registries defines what the registries
read, and a new analysis is one file and one line, followed here once with a throwaway analysis."""

import importlib
import json
import math
import sys
import textwrap

import pytest

import autobal
from autobal import analyses, parts, report, scenario
from autobal.errors import ScenarioError
from autobal.schema import Strict


@pytest.mark.parametrize("key", list(analyses.MODULES))
def test_every_analysis_room_defines_what_the_registry_reads(key):
    room = analyses.module(key)
    assert issubclass(room.SETTINGS, Strict)
    assert isinstance(room.DESCRIPTION, str) and room.DESCRIPTION
    # the part it needs is a part of the registry (or device.dynamics), checked at load time
    assert room.NEEDS is None or room.NEEDS.split(".")[0] in parts.MODULES
    assert callable(room.run) and callable(room.estimate_seconds)
    # its report section lives in the room and is the one report.py draws its results with; the module it
    # names declares every number of its block
    assert callable(room.report_section) and report.SECTIONS[key] is room.report_section
    assert report.DECLARED[key] == room.QUANTITIES_MODULE
    assert report.declarations(key) is importlib.import_module(room.QUANTITIES_MODULE).QUANTITIES
    assert isinstance(room.TITLE, str) and report.TITLES[key] == room.TITLE
    assert not hasattr(room, "REPORT_SECTION")
    assert scenario.Scenario.model_fields["analyses"].annotation.model_fields[key].description.startswith(
        room.DESCRIPTION)


@pytest.mark.parametrize("key", list(parts.MODULES))
def test_every_part_room_defines_its_schema(key):
    part = parts.module(key)
    assert isinstance(part.DESCRIPTION, str) and part.DESCRIPTION
    assert issubclass(part.device_model(True) if key == "device" else part.SCHEMA, Strict)


def test_the_estimates_of_the_shipped_scenes_are_positive_and_finite():
    named = set()
    for path in scenario.shipped():
        scene = scenario.load(path)
        est = analyses.estimate_seconds(scene)
        assert list(est) == analyses.named(scene), path.stem
        assert all(1.0 <= t < 3600 and math.isfinite(t) for t in est.values()), (path.stem, est)
        named |= set(est)
    assert named == set(analyses.MODULES)  # every analysis has a shipped scene that prices it


def test_the_accuracy_studies_are_those_of_the_rooms():
    assert set(analyses.accuracy_studies()) == {"statics", "transient", "estimation", "spinup"}


# ---- docs/contributing.md followed once: a throwaway analysis, one file and one line --------------------

ROOM = '''
"""``analyses.area_base``: the area s = T_n / p over which a pressure p carries the nominal thrust T_n;
at the nominal pressure, the area base s_B of the dimensionless groups (Pavlenko (2014), Eq. (2.18))."""

from pydantic import Field

from autobal.analyses import COST
from autobal.analysis.run.quantities import Declarations, Quantity
from autobal.analysis.run.result import Result
from autobal.schema import Strict
from autobal.units import Pressure

DESCRIPTION = "area carrying the nominal thrust"
NEEDS = "device"
QUANTITIES_MODULE = "area_base_room"  # this file: its QUANTITIES below
TITLE = "Area base"
QUANTITIES = Declarations(Quantity("area", "m^2", "s", "area carrying the nominal thrust", display="cm²",
                                   headline=True))


class AreaBase(Strict):
    """The pressure at which the area is reported."""

    pressure: Pressure | None = Field(None, description="p; default the nominal pressure p_n")


SETTINGS = AreaBase


class AreaBaseResult(Result):
    name = "area_base"

    def __init__(self, area: float):
        self.area = area

    def to_dict(self) -> dict:
        return {"area": self.area}

    def summary(self) -> str:
        return f"area carrying the nominal thrust: {self.area * 1e4:.4g} cm^2"


def run(scene, settings: AreaBase) -> AreaBaseResult:
    from autobal.parts.device import adapt

    op = adapt(scene.device).operating
    return AreaBaseResult(op.nominal_thrust / (settings.pressure or op.nominal_pressure))


def estimate_seconds(settings: AreaBase) -> float:
    return COST["start"]


def report_section(sec) -> None:
    sec.row("area carrying the nominal thrust", "s", "area")
    sec.verdict(None, "the area base s_B at the nominal pressure")
'''


@pytest.fixture
def area_base(tmp_path, monkeypatch):
    """The throwaway room written as a file and registered with its one line of ``analyses.MODULES``."""
    (tmp_path / "area_base_room.py").write_text(textwrap.dedent(ROOM))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(analyses.MODULES, "area_base", "area_base_room")
    scenario.analyses_model.cache_clear()  # the scene models are built from the registry once per combination
    scenario.scenario_model.cache_clear()
    yield
    scenario.analyses_model.cache_clear()
    scenario.scenario_model.cache_clear()
    sys.modules.pop("area_base_room", None)


def _scene(tmp_path, settings, device=True) -> str:
    data = scenario.read(scenario.resolve("pump_pe600_statics"))
    data["name"] = "area_base"
    data["analyses"] = {"area_base": settings}
    if not device:
        del data["device"]
    path = tmp_path / "area_base.yaml"
    path.write_text(json.dumps(data))  # JSON is YAML
    return str(path)


@pytest.mark.cli
def test_a_new_analysis_is_one_file_and_one_line(area_base, tmp_path):
    scene = autobal.load(_scene(tmp_path, {"pressure": "20 MPa"}))
    assert scene.analyses.area_base.pressure == 2e7  # validated by its schema, in SI
    assert analyses.estimate_seconds(scene) == {"area_base": 1.0}
    run = autobal.run(scene, out=tmp_path / "out")
    # independent of the room: the thrust over 20 MPa from the scene's own numbers
    thrust = scenario.read(scenario.resolve("pump_pe600_statics"))["device"]["operating"]["nominal_thrust"]
    assert thrust == "3.3e5 N"
    assert run["area_base"].area == pytest.approx(3.3e5 / 20e6, rel=1e-12)
    out = json.loads((tmp_path / "out" / "results.json").read_text())
    assert out["area_base"]["area"] == pytest.approx(0.0165, rel=1e-12) and out["status"] == "ok"
    # its unit from the QUANTITIES its room names, its report section from its room: 165 cm² in report.html
    assert out["units"]["area_base.area"] == "m^2"
    assert report.SECTIONS["area_base"] is sys.modules["area_base_room"].report_section
    (sec,) = report.sections(out)
    assert sec["title"] == "Area base"
    assert sec["overall"]["text"] == "the area base s_B at the nominal pressure"
    page = (tmp_path / "out" / "report.html").read_text()
    assert 'data-key="area_base.area"' in page and "165" in page and "cm²" in page
    # at the nominal pressure the area is the area base s_B of the device's dimensionless groups
    nominal = autobal.run(autobal.load(_scene(tmp_path, {})))
    from autobal.parts.device import design

    assert nominal["area_base"].area == pytest.approx(design(scene.device).scales["s_B"], rel=1e-12)


def test_a_new_analysis_has_its_settings_and_its_part_checked(area_base, tmp_path):
    with pytest.raises(ScenarioError, match=r"analyses\.area_base\.pressure: .*pressure"):
        autobal.load(_scene(tmp_path, {"pressure": "20 kg"}))
    with pytest.raises(ScenarioError, match=r"analyses\.area_base\.thrust: unknown key"):
        autobal.load(_scene(tmp_path, {"thrust": "1 kN"}))
    with pytest.raises(ScenarioError, match=r"analyses\.area_base needs a device section"):
        autobal.load(_scene(tmp_path, {}, device=False))


# ---- each device parameter declared once: the scene schema derived from models/device.py ----------------

def _device_dataclasses():
    import dataclasses

    from autobal.models import device as dv

    seen, queue = [], [dv.DeviceParams]
    while queue:
        cls = queue.pop()
        seen.append(cls)
        for f in dataclasses.fields(cls):
            part = getattr(dv, str(f.type).split(" ")[0], None)
            if dataclasses.is_dataclass(part) and part not in seen:
                queue.append(part)
    return seen


def test_every_device_parameter_is_declared_with_its_unit_kind_and_meaning():
    import dataclasses

    from autobal.units import DIMENSIONS

    classes = _device_dataclasses()
    assert {c.__name__ for c in classes} >= {"Fluid", "Impeller", "Operating", "InnerSeal", "OuterSeal", "Face",
                                             "Disc", "Tube", "Barrier", "Valve", "Regulator", "DeviceParams"}
    for cls in classes:
        for f in dataclasses.fields(cls):
            if f.name == "dynamics":
                continue
            assert f.metadata.get("doc"), f"{cls.__name__}.{f.name}"
            if f.metadata.get("kind"):  # the declared SI unit is the unit of its quantity kind
                assert DIMENSIONS[f.metadata["kind"]][1] == f.metadata["unit"], f"{cls.__name__}.{f.name}"
            elif "unit" in f.metadata:
                assert f.metadata["unit"] == "" and f.metadata["bounds"], f"{cls.__name__}.{f.name}"


def test_the_device_schema_is_the_dataclasses_and_the_adapter_builds_them(tmp_path):
    from autobal.models import device as dv
    from autobal.parts import device

    scene = scenario.load("compressor_k180_dynamics")  # a gas device with a regulator and a travel limit
    params = device.adapt(scene.device)
    assert isinstance(params, dv.DeviceParams) and params.dynamics is not None
    assert params.regulator.valve.max_opening == scene.device.regulator.valve.max_opening
    # an omitted optional value is the dataclass' default: the thrust ratio NaN (from the impeller), no travel
    # limit inf, no normal pressure (a liquid) NaN
    data = scenario.read(scenario.resolve("pump_pe600_statics"))
    del data["device"]["operating"]["thrust_ratio"], data["device"]["regulator"]["valve"]["max_opening"]
    path = tmp_path / "omitted.yaml"
    path.write_text(json.dumps(data))
    omitted = device.adapt(scenario.load(path).device)
    assert math.isnan(omitted.operating.thrust_ratio) and math.isnan(omitted.fluid.normal_pressure)
    assert omitted.regulator.valve.max_opening == math.inf
    assert device.design(scenario.load(path).device).groups.b == pytest.approx(0.8327, abs=5e-5)  # App. A data
    assert set(device.schema(dv.Face).model_fields) == {"inner_diameter", "outer_diameter", "base_gap", "friction"}
    # the checks across fields live with the dataclass and refuse a scene with one line naming the section
    data = scenario.read(scenario.resolve("pump_pe600_statics"))
    data["device"]["disc"]["face"]["outer_diameter"] = data["device"]["disc"]["face"]["inner_diameter"]
    path = tmp_path / "bad.yaml"
    path.write_text(json.dumps(data))
    with pytest.raises(ScenarioError, match=r"device\.disc\.face: outer_diameter must be larger than inner_diameter"):
        scenario.load(path)
    with pytest.raises(ValueError, match="outer_diameter must be larger"):
        dv.Face(0.2, 0.1, 1e-4)


def test_a_design_at_its_sample_bound_is_announced_as_long():
    # the design's estimate (it had none before the rooms): the shipped scenes are short, 100,000 samples not
    small = scenario.load("pump_pe600_design")
    big = scenario.load("pump_pe600_design", overrides={"analyses.design.samples": 100_000})
    assert analyses.long_run_note(small) is None
    assert analyses.estimate_seconds(big)["design"] > 400 * analyses.estimate_seconds(small)["design"] / 2
    assert analyses.long_run_note(big).startswith("this run is estimated to take about")
