"""Studies take typed specs: each study of ``analysis/`` takes a frozen spec dataclass of plain SI values, built by
its room (``autobal/analyses/<key>.py``, ``spec(settings)``) from the validated settings; the study never sees a
schema object or a file reader it was not handed."""

import ast
import dataclasses
import inspect

import pytest
from pydantic import BaseModel

from autobal import scenario
from autobal.analyses import design, estimation, liquid_balancer, montecarlo, reliability, rotor_dynamics, statics
from autobal.analysis.studies import design_study, estimation_study, rotor_study, statics_study
from autobal.analysis.studies import liquid_balancer as liquid_balancer_study
from autobal.analysis.studies import montecarlo as montecarlo_study
from autobal.analysis.studies import reliability as reliability_study

#: the studies that take a spec: their modules read no schema, no file and no settings
STUDIES = (estimation_study, liquid_balancer_study, montecarlo_study, reliability_study, rotor_study, design_study,
           statics_study)
#: what a study may not import: the schema, its settings, the scene parts, the file readers
FRONT_DOOR = ("pydantic", "autobal.schema", "autobal.analyses", "autobal.parts", "autobal.measurements",
              "autobal.scenario", "autobal.units")
#: each room with a shipped scene of its analysis
ROOMS = [(estimation, "rig_table43_fit"), (liquid_balancer, "washer_liquid_balancer"),
         (liquid_balancer, "washer_liquid_balancer_nested"), (montecarlo, "pump_pe600_montecarlo"),
         (reliability, "hydroheel_wear"), (rotor_dynamics, "pashkov_runup"),
         (rotor_dynamics, "spinup_liquid_balancer"), (statics, "pump_pe600_statics"), (design, "pump_pe600_design")]


def _motor(scene):
    """The scene's rotor.drive.motor, or None."""
    return scene.rotor.drive.motor if scene.rotor.drive else None


def _plain(value, path: str) -> list[str]:
    """The paths under ``value`` that are not plain data: a schema object, or a dataclass that is not frozen."""
    if isinstance(value, BaseModel):
        return [f"{path}: {type(value).__name__} (a schema object)"]
    if dataclasses.is_dataclass(value):
        bad = [] if value.__dataclass_params__.frozen else [f"{path}: {type(value).__name__} is not frozen"]
        return bad + [p for f in dataclasses.fields(value) for p in _plain(getattr(value, f.name), f"{path}.{f.name}")]
    if isinstance(value, dict):
        return [p for k, v in value.items() for p in _plain(v, f"{path}.{k}")]
    if isinstance(value, (list, tuple)):
        return [p for i, v in enumerate(value) for p in _plain(v, f"{path}[{i}]")]
    return [] if value is None or isinstance(value, (bool, int, float, str)) else [f"{path}: {type(value).__name__}"]


@pytest.mark.parametrize("room, name", ROOMS, ids=[name for _, name in ROOMS])
def test_the_room_hands_its_study_a_frozen_spec_of_plain_values(room, name):
    scene = scenario.load(name)
    key = room.__name__.rsplit(".", 1)[1]
    settings = getattr(scene.analyses, key)
    args = (settings, _motor(scene)) if room is rotor_dynamics else (settings,)
    spec = room.spec(*args)
    # the study's own Spec (the design study's is of its NLP, analysis/numerics/design.py)
    assert type(spec).__name__ == "Spec"
    assert type(spec).__module__ in (room.QUANTITIES_MODULE, "autobal.analysis.numerics.design")
    # the loss coefficient's DiscLosses is a model parameter object: frozen data as well
    assert _plain(spec, "spec") == []
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.__setattr__(dataclasses.fields(spec)[0].name, None)


def test_a_spec_carries_the_settings_values_unchanged():
    """The spec is the settings in SI, not a conversion of them: the shipped scenes' values come through as they
    were validated (the run's results are bit-identical with the settings handed over before)."""
    lb = scenario.load("washer_liquid_balancer").analyses.liquid_balancer
    s = liquid_balancer.spec(lb)
    assert s.speed_ratio == (lb.speed_ratio.start, lb.speed_ratio.stop, lb.speed_ratio.points)
    assert s.table_ratios == tuple(lb.table_ratios) and s.variant == lb.variant
    rd = scenario.load("pashkov_runup")
    r = rotor_dynamics.spec(rd.analyses.rotor_dynamics, _motor(rd))
    assert r.passage.acceleration == rd.analyses.rotor_dynamics.passage.acceleration
    assert r.stationary.cases == tuple(rd.analyses.rotor_dynamics.stationary.cases)
    lq = scenario.load("spinup_liquid_balancer")
    m = rotor_dynamics.spec(lq.analyses.rotor_dynamics, _motor(lq)).motor_runup
    assert (m.duration, m.stall_torque, m.no_load_speed) == (6.0, 0.12, 250.0)
    e = scenario.load("rig_table43_fit").analyses.estimation
    es = estimation.spec(e)
    assert [f.name for f in es.fits] == [f.name for f in e.fits]
    assert es.bases == e.bases.values() and es.fits[0].free() == e.fits[0].free()


def test_a_motor_runup_without_a_motor_is_refused_by_the_study():
    from autobal.errors import ScenarioError
    from autobal.models.rotor import RotorParams

    spec = rotor_study.Spec(motor_runup=rotor_study.MotorRunupSpec(duration=1.0))
    with pytest.raises(ScenarioError, match="motor_runup needs rotor.drive.motor"):
        rotor_study.run(RotorParams.from_groups(Omega0=100.0, chi_over_m1=2.0, psi=0.5), spec)


@pytest.mark.parametrize("study", STUDIES, ids=[m.__name__.rsplit(".", 1)[1] for m in STUDIES])
def test_a_study_reads_no_schema_and_no_settings(study):
    """Its module imports none of the front door's schema, parts or readers, and no name it reads is ``settings``
    (a field of its Result may be)."""
    tree = ast.parse(inspect.getsource(study))
    imported = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)] + [
        a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert [m for m in imported if m and m.startswith(FRONT_DOOR)] == []
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)} | {
        a.arg for n in ast.walk(tree) if isinstance(n, ast.arguments) for a in (*n.args, *n.kwonlyargs)}
    assert "settings" not in names
