"""Scenario files: YAML scenes with units, validated into SI at load time.

Every field is documented in README.md ("Scenario format").  A bad file raises
:class:`autobal.errors.ScenarioError` with one line naming the file, the field and the
expected unit.
"""

from __future__ import annotations

import hashlib
import numbers
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Annotated

import yaml
from pydantic import Field, PrivateAttr, ValidationError, ValidationInfo, create_model, field_validator, model_validator

from autobal import analyses, parts
from autobal.errors import ScenarioError
from autobal.paths import SCENARIO_DIR
from autobal.schema import Display, Strict, section_at
from autobal.text import LIMIT, clean
from autobal.units import clip


def _d(text: str, default=..., **kw):
    """A field with its meaning for the schema reference (units are added by the quantity types)."""
    return Field(default, description=text, **kw)


def _analysis_field(key: str, named: bool):
    """The optional field ``analyses.<key>``: its schema (from its module) when the scene names it, else one
    that admits only its absence (and imports nothing)."""
    if not named:
        return (None, Field(None))
    room = analyses.module(key)
    text = f"{room.DESCRIPTION}; needs {room.NEEDS}" if room.NEEDS else room.DESCRIPTION
    return (room.SETTINGS | None, _d(text, None))


def _part_field(key: str, named: bool, dynamics: bool):
    """The optional top-level field ``<key>`` of a scene part, as :func:`_analysis_field`."""
    if not named:
        return (None, Field(None))
    part = parts.module(key)
    schema = part.device_model(dynamics) if key == "device" else part.SCHEMA
    return (schema | None, _d(part.DESCRIPTION, None))


def _empty_analysis(cls, value, info: ValidationInfo):
    """``analyses.<key>`` given with no settings (``stability:`` or ``stability: {}``): the analysis with its
    defaults when every setting has one; else one line naming the key and the settings it needs (YAML reads an
    empty key as null, which would otherwise mean 'not named')."""
    if value is None or (isinstance(value, dict) and not value):
        needs = [k for k, f in analyses.module(info.field_name).SETTINGS.model_fields.items() if f.is_required()]
        if needs:
            raise ValueError(f"given without settings; it needs {', '.join(needs)} (docs/schema.md)")
        return {}
    return value


@cache
def analyses_model(named: frozenset[str]) -> type[Strict]:
    """The ``Analyses`` model with the schemas of the analyses in ``named``; the others must be absent."""
    return create_model("Analyses", __base__=Strict, __module__=__name__,
                        __doc__="The analyses to run; at least one.",
                        __validators__={"_empty": field_validator(*named, mode="before")(_empty_analysis)}
                        if named else None,
                        **{k: _analysis_field(k, k in named) for k in analyses.MODULES})


# a scene's name names its output folder: a plain file name, never a path
NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$"
PRINTABLE = r"^[^\x00-\x1f\x7f-\x9f]*$"  # one line of text: no control characters (C0, DEL, C1)
PRINTABLE_LINES = r"^[^\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]*$"  # text: tabs and line breaks allowed, no escapes


class BaseScenario(Strict):
    """What every scene model shares: its identity and the check that each analysis has its parts.

    The concrete models (``Scenario``, and the slimmer ones :func:`model_for` builds for one scene)
    add the parts and the analyses.
    """

    name: Annotated[str, Field(pattern=NAME_PATTERN)] = _d(
        "identifier of the scene and of its default output folder out/<name>: letters, digits, _ - . "
        "(no path separators, no '..', at most 100 characters)")
    title: Annotated[str, Field(max_length=500, pattern=PRINTABLE)] = _d(
        "one line of text (no control characters), printed on figures")
    source: Annotated[str, Field(max_length=2000, pattern=PRINTABLE_LINES)] = _d(
        "where the inputs come from: plain text (line breaks allowed, no terminal escapes)", "")
    display: Display | None = _d("the units a person reads, by kind of quantity (results.json stays SI)", None)
    _origin: dict = PrivateAttr(default_factory=dict)  # file, sha256, overrides (set by load)

    @model_validator(mode="after")
    def _parts_for_analyses(self):
        if ".." in self.name:
            raise ValueError("name: must not contain '..' (a plain identifier: letters, digits, _ - .)")
        if not any(v is not None for _, v in self.analyses):
            raise ValueError(f"analyses: the scene names no analysis (one or more of "
                             f"{', '.join(analyses.MODULES)})")
        for analysis in analyses.named(self):
            path = analyses.module(analysis).NEEDS
            if path is None:
                continue
            if section_at(self, path) is None:
                raise ValueError(f"analyses.{analysis} needs a {path} section")
        return self


@cache
def scenario_model(named_parts: frozenset[str], named_analyses: frozenset[str], dynamics: bool) -> type[BaseScenario]:
    """A ``Scenario`` model with the schemas of the named scene parts, analyses and (True) of
    ``device.dynamics``; every part or analysis not named must be absent from the scene.

    Parameters
    ----------
    named_parts : frozenset of str
        Keys of :data:`autobal.parts.MODULES` to validate.
    named_analyses : frozenset of str
        Keys of :data:`autobal.analyses.MODULES` to validate.
    dynamics : bool
        Validate ``device.dynamics``.

    Returns
    -------
    type
        A pydantic model named ``Scenario``.
    """
    fields = {k: _part_field(k, k in named_parts, dynamics) for k in parts.MODULES}
    fields["analyses"] = (analyses_model(named_analyses), _d("the analyses to run"))
    return create_model("Scenario", __base__=BaseScenario, __module__=__name__,
                        __doc__="A scene: the machine's parts and the analyses to run on them.", **fields)


def model_for(data) -> type[BaseScenario]:
    """The model that validates a scene mapping exactly as ``Scenario`` does, built from the schemas of
    the parts and analyses it names only (all of them when it is not a mapping of mappings).

    Parameters
    ----------
    data : dict
        A scene as read from YAML.

    Returns
    -------
    type
        A subclass of :class:`BaseScenario`.
    """
    if not isinstance(data, dict) or not isinstance(data.get("analyses"), dict):
        return scenario_model(frozenset(parts.MODULES), frozenset(analyses.MODULES), True)
    device = data.get("device")
    return scenario_model(frozenset(parts.MODULES).intersection(data),
                          frozenset(analyses.MODULES).intersection(data["analyses"]),
                          not isinstance(device, dict) or "dynamics" in device)


def __getattr__(name: str):
    """``Scenario``, ``Analyses`` and ``Device`` with every schema, built on first use."""
    if name == "Scenario":
        return scenario_model(frozenset(parts.MODULES), frozenset(analyses.MODULES), True)
    if name == "Analyses":
        return analyses_model(frozenset(analyses.MODULES))
    if name == "Device":
        return parts.module("device").device_model(True)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


MAX_FILE_BYTES = 1_000_000  # a scene is a page of YAML; anything larger is not a scene
MAX_NODES = 100_000  # values in a scene after YAML aliases are expanded (refuses "billion laughs" files)


def _one_line(err: ValidationError) -> str:
    e = err.errors()[0]
    where = clean(".".join(str(p) for p in e["loc"]) or "(top level)")
    msg = clean(e["msg"].removeprefix("Value error, "), 2 * LIMIT)
    if e["type"] == "extra_forbidden":
        msg = "unknown key"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("name",):
        msg = f"{clean(repr(e['input']))} is not a plain identifier (letters, digits, _ - .; no path separators)"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("title",):
        msg = "control characters (terminal escapes, tabs, line breaks) are not allowed; write one line of text"
    elif e["type"] == "string_pattern_mismatch" and e["loc"] == ("source",):
        msg = "control characters (terminal escapes) are not allowed; write plain text"
    elif e["type"] == "finite_number":
        msg = f"{clean(repr(e['input']))}: must be a finite number"
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    return f"{where}: {msg}{more}"


def resolve(name_or_path: str | Path) -> Path:
    """A scenario path, or the name of a shipped scenario (``scenarios/NAME.yaml``).

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario such as ``"pump_pe600_statics"``.

    Returns
    -------
    Path
    """
    p = Path(name_or_path)
    try:
        if p.is_file():
            return p
        shipped = SCENARIO_DIR / f"{p.stem}.yaml"
        if p.suffix in ("", ".yaml") and shipped.is_file() and p.parent == Path("."):
            return shipped
        if p.is_dir():
            raise ScenarioError(f"{clean(name_or_path)}: is a folder, not a scenario file")
    except OSError as exc:  # a name too long for the file system, a folder that cannot be searched
        raise ScenarioError(f"{clean(name_or_path)}: cannot be read ({exc.strerror})") from None
    raise ScenarioError(f"{clean(name_or_path)}: no such scenario file or shipped scenario (see 'autobal list')")


def _set(data: dict, path: str, value) -> None:
    """Set the key at the dotted ``path`` of a scene mapping (list items by index), making the
    mappings on the way; a string value is read as YAML ("3" -> 3, "0.18 mm" stays a string)."""
    if isinstance(value, str):
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError:
            pass
    elif hasattr(value, "units") and hasattr(value, "magnitude"):  # a pint Quantity
        value = f"{value.magnitude!r} {value.units}"
    keys = path.split(".")
    node = data
    for i, key in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(node, list):
            if not key.isdigit() or int(key) >= len(node):
                raise ScenarioError(f"set {path}: {'.'.join(keys[:i])} has no item {key}")
            key = int(key)
        elif not isinstance(node, dict):
            raise ScenarioError(f"set {path}: {'.'.join(keys[:i]) or '(top level)'} is not a mapping")
        elif not last and node.get(key) is None:
            node[key] = {}
        if last:
            node[key] = value
        else:
            node = node[key]


class _UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses a key given twice in one mapping (PyYAML keeps the last).  Anchors, aliases
    and merge keys (``outer_seal: {<<: *seal, length: 40 mm}``, YAML 1.1) are read: a key of the mapping itself
    overrides a merged one, as YAML says; still no custom tags, so nothing but plain data is built."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # '<<': merged by SafeLoader.flatten_mapping
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise yaml.constructor.ConstructorError(None, None, "a key must be a plain value",
                                                        key_node.start_mark) from None
            if key in seen:
                raise ScenarioError(f"duplicate key {key!r} at line {key_node.start_mark.line + 1} "
                                    f"(first at line {seen[key]})")
            seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


def _count(node, budget: list[int]) -> None:
    budget[0] -= 1
    if budget[0] < 0:
        raise ScenarioError(f"more than {MAX_NODES} values (YAML aliases expanded): not a scene")
    children = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
    for child in children:
        _count(child, budget)


def read(path: Path) -> dict:
    """The YAML mapping of a scenario file, checked as text: UTF-8, not binary, at most
    :data:`MAX_FILE_BYTES`, no duplicate keys; ScenarioError with one line otherwise.

    Parameters
    ----------
    path : Path
        The scenario file.

    Returns
    -------
    dict
        The parsed scene, not yet validated.
    """
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ScenarioError(f"{path}: {size} bytes: a scenario is a YAML text of at most {MAX_FILE_BYTES} bytes")
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if b"\0" in raw[:8192]:
        raise ScenarioError(f"{path}: a binary file, not a YAML scenario")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            f"save the scenario as UTF-8") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: a scenario is a YAML mapping of keys to values")
    try:
        _count(data, [MAX_NODES])
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    return data


def _checked_overrides(overrides) -> dict:
    """A copy of the overrides mapping after checking its type, its keys (dotted paths) and its values (a string,
    number, bool, None, pint quantity, or a list or mapping of these as YAML gives them); ScenarioError otherwise."""
    if overrides is None:
        return {}
    if not isinstance(overrides, Mapping):
        raise ScenarioError(f"set: a mapping of dotted scene paths to values, e.g. {{'device.disc.outer_seal.length': "
                            f"'300 mm'}}; got {type(overrides).__name__}")
    for key, value in overrides.items():
        if not isinstance(key, str) or not key.strip() or any(not k for k in key.split(".")):
            raise ScenarioError(f"set: {key!r} is not a dotted scene path such as 'device.disc.outer_seal.length'")
        if not _plain(value) and not (hasattr(value, "units") and hasattr(value, "magnitude")):
            raise ScenarioError(f"set {key}: a value of type {type(value).__name__} is not a scene value (give a "
                                "string with its unit, a number, a list or a mapping)")
    return dict(overrides)


def _plain(value) -> bool:
    """A value YAML could have given: str, a real number (bool too), None, lists and string-keyed mappings of them."""
    if value is None or isinstance(value, str | numbers.Real):
        return True
    if isinstance(value, list | tuple):
        return all(_plain(v) for v in value)
    if isinstance(value, Mapping):
        return all(isinstance(k, str) and _plain(v) for k, v in value.items())
    return False


def load(name_or_path: str | Path, overrides: dict | None = None) -> BaseScenario:
    """Read, validate and convert a scenario to SI; raise ScenarioError with one line.

    Parameters
    ----------
    name_or_path : str or Path
        A YAML file, or the name of a shipped scenario.
    overrides : dict, optional
        Dotted scene paths -> values (``{"device.disc.outer_seal.length": "300 mm"}``), applied to
        the file's content before validation, so they are checked exactly like YAML.

    Returns
    -------
    Scenario
        The validated scene, every quantity in SI.
    """
    overrides = _checked_overrides(overrides)
    path = resolve(name_or_path)
    data = read(path)
    for key, value in overrides.items():
        _set(data, key, value)
    try:
        scn = model_for(data).model_validate(data, context={"folder": path.absolute().parent, "overrides": overrides})
    except ValidationError as exc:
        loc = ".".join(str(p) for p in exc.errors()[0]["loc"])
        hit = next((k for k in overrides if loc == k or loc.startswith(k + ".") or (loc and k.startswith(loc + "."))),
                   None)
        where = f"set {clean(hit)}={clip(str(overrides[hit]))}" if hit else clean(path)
        raise ScenarioError(f"{where}: {_one_line(exc)}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    scn._origin = {"file": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                   "overrides": {k: str(v) for k, v in overrides.items()}}
    return scn


def shipped() -> list[Path]:
    return sorted(SCENARIO_DIR.glob("*.yaml"))
