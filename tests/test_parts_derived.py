"""The scene schemas of the parts derived from the SI parameter dataclasses of models/ (autobal/parts/derived.py):
every shipped scene adapts to the same SI parameter objects as the hand-written schemas did, and each
parameter is declared once."""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path

import pytest

import autobal
from autobal.parts import module

SCENES = Path(__file__).parents[1] / "scenarios"
# the parameter objects of every shipped scene's parts, recorded from main before the schemas were derived
# (commit 14ec08f, hand-written schemas and adapters; ross_spinup_time_optimal.yaml under the same code at
# c7b2817); floats as repr, so the comparison is exact
RECORDED = json.loads((Path(__file__).parent / "data" / "part_params.json").read_text())


def plain(value):
    """A parameter object as JSON-able data: dataclasses by class name and fields, floats as repr."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__class__": type(value).__name__,
                **{f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, tuple | list):
        return [plain(v) for v in value]
    return repr(value) if isinstance(value, float) else value


def adapted(path: Path) -> dict:
    scn = autobal.load(path)
    return {key: plain(module(key).adapt(getattr(scn, key)))
            for key in ("device", "liquid_balancer", "rotor", "ross_rotor") if getattr(scn, key, None) is not None}


@pytest.mark.parametrize("name", sorted(RECORDED))
def test_shipped_scene_adapts_to_the_recorded_parameters(name):
    assert adapted(SCENES / name) == RECORDED[name]


def test_every_shipped_scene_is_recorded():
    shipped = {str(p.relative_to(SCENES)) for pattern in ("*.yaml", "examples/*.yaml", "extreme/*.yaml")
               for p in SCENES.glob(pattern)}
    assert shipped == set(RECORDED)
    parts = {key for rec in RECORDED.values() for key in rec}
    assert parts == {"device", "liquid_balancer", "rotor", "ross_rotor"}



def _inner(annotation) -> list:
    """The section models in a field's annotation (through X | None and lists)."""
    from pydantic import BaseModel

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in typing.get_args(annotation) for m in _inner(a)]


def _declarations(model, out: dict) -> dict:
    """(model, field name) -> the dataclass field it is derived from, for ``model`` and the sections inside it."""
    from autobal.parts import derived

    cls = next((derived._PARAMS[c] for c in model.__mro__ if c in derived._PARAMS), None)
    for f in dataclasses.fields(cls) if cls else ():
        key = derived.key(f)
        if key is not None:
            *group, name = key.split(".")
            section = _inner(model.model_fields[group[0]].annotation)[0] if group else model
            out[section, name] = f
    for field in model.model_fields.values():
        for inner in _inner(field.annotation):
            _declarations(inner, out)
    return out


# the scene-only inputs written by hand in the part modules (no field of their own in the model's dataclass:
# alternatives, a datasheet form, repetitions, degrees, the drive's limits for the spin-up), by model and key;
# the sections that only compose others (rotor.unbalance, ross_rotor.shaft, ...) are left out
HANDWRITTEN = {
    "LBRotor": {"log_decrement"}, "LBChamber": {"inclination_deg"}, "NestedChamber": {"radius", "volume"},
    "Rotor": {"critical_speed", "damping_ratio"}, "Unbalance": {"grade", "service_speed", "residual"},
    "Liquid": {"psi"}, "Drive": {"max_torque", "max_power", "max_braking_torque", "max_deceleration"},
    "Motor": {"stall_torque", "no_load_speed"}, "RossRotor": {"example"}, "RossShaft": {"count"},
    "RossUnbalance": {"phase"},
}


def test_each_scene_parameter_is_declared_once_in_its_dataclass():
    from autobal.parts.device import device_model
    from autobal.schema import _quantity_extra

    roots = [device_model(True), *(module(k).SCHEMA for k in ("liquid_balancer", "rotor", "ross_rotor"))]
    declared, handwritten = {}, {}
    for root in roots:
        _declarations(root, declared)
    models = {m for (m, _) in declared} | {i for m in list(declared) for f in m[0].model_fields.values()
                                           for i in _inner(f.annotation)} | set(roots)
    for model in models:
        for name, field in model.model_fields.items():
            f = declared.get((model, name))
            if f is None:
                if not _inner(field.annotation):
                    handwritten.setdefault(model.__name__, set()).add(name)
                continue
            # the scene's field says what its declaration says: meaning, quantity kind
            assert field.description.startswith(f.metadata["doc"]), (model.__name__, name)
            kind = _quantity_extra(field.json_schema_extra, field.annotation, "kind")
            assert kind == (f.metadata.get("kind") or None), (model.__name__, name, kind)
    assert handwritten == HANDWRITTEN
    assert len(declared) == 106  # device 48, its dynamics 14, liquid balancer 15, rotor 10, ROSS elements 19
