"""The scene schemas of the parts derived from the SI parameter dataclasses of models/ (autobal/parts/derived.py):
every shipped scene adapts to the same SI parameter objects as the hand-written schemas did, and each
parameter is declared once."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

import autobal
from autobal.parts import module

SCENES = Path(__file__).parents[1] / "scenarios"
# the parameter objects of every shipped scene's parts, recorded from main before the schemas were derived
# (commit 14ec08f, hand-written schemas and adapters); floats as repr, so the comparison is exact
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
