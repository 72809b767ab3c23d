"""Typed Results: a Result as a frozen dataclass whose fields carry their declarations.

A typed Result (:class:`TypedResult`) and its nested blocks (:class:`Record`) are frozen dataclasses, made with
:func:`record`.  A field is one of

- a number, or an array or list of numbers, declared with :func:`quantity` (unit, symbol, meaning, display unit,
  source: a :class:`~autobal.analysis.run.quantities.Quantity` without its key, which is the field's path);
- words or a flag (a plain field: ``title: str``, ``stable: bool``);
- a nested record (``margin: Margin``), a mapping of names to records (``models: dict[str, ModelVerdict]``, key
  path ``models.*.``) or a list of records (``unstable_modes: list[Mode]``, key path ``unstable_modes[].``);
- a block whose keys are names with units of their own (``coefficients: dict``), declared by the Result's extra
  declarations;
- what the Result holds for its tables and figures but results.json does not (a curve on its grid, written as
  CSV; re-simulations, samples), declared with :func:`unsaved`: not in ``to_dict()``, not compared, its default
  in a Result rebuilt by ``from_dict``.

A null says why: a record's ``statuses`` (filled by :func:`explained`) are written as ``<key>_status`` right after
their keys; a Result that sets ``null_reasons`` (:class:`TypedResult`) has them made from its nulls by
``to_dict()``; ``from_dict()`` keeps the statuses it reads in ``statuses``.

From the fields come ``to_dict()`` (the results.json block, keys in field order; an :func:`optional` field that
is None is left out), ``from_dict()`` (its inverse: ``to_dict(from_dict(d)) == d``), :func:`declarations` (the
Declarations of every key path, hence the ``units`` map, the summary's and the report's headline rows) and
:func:`key_paths`.  Why a value is null (its ``<key>_status`` in results.json) is in the record's ``statuses``,
filled in by :func:`explained`.  A key renamed in a field breaks ``from_dict`` of an old block (an unknown or
missing key is an error, not a silent None) and every attribute access of the old name.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from dataclasses import dataclass, field

import numpy as np

from autobal.analysis.run.quantities import Declarations, Quantity
from autobal.analysis.run.result import Failures, Result, plain, with_statuses

QUANTITY = "autobal.quantity"  # field metadata: the declaration's arguments
OMIT = "autobal.omit"  # field metadata: left out of to_dict() when None (a block the analysis did not compute)
KEY = "autobal.key"  # field metadata: its key in results.json where that is not the field's name
STATUSES = "autobal.statuses"  # field metadata: the record's statuses (why a value is null), not a key of its own
UNSAVED = "autobal.unsaved"  # field metadata: held in memory only, not in results.json (see unsaved())
STATUS = "_status"  # the suffix of the key that says why the value of its key is null

#: what a frozen Result still takes after it is made: not its numbers, what a run sets on every Result (the display
#: units of its scene)
SETTABLE = ("display_choice",)


def record(cls=None, *, kw_only: bool = False):
    """``cls`` as a frozen dataclass compared by its results.json block (numpy arrays have no ``==`` a dataclass
    could use); its fields cannot be assigned, the names of :data:`SETTABLE` can.  ``@record(kw_only=True)``: its
    fields are keywords of the constructor (a block whose optional keys come before keys it always has)."""
    if cls is None:
        return lambda c: record(c, kw_only=kw_only)
    cls = dataclass(frozen=True, eq=False, kw_only=kw_only)(cls)
    frozen = cls.__setattr__

    def __setattr__(self, name, value):
        if name in SETTABLE:
            object.__setattr__(self, name, value)
        else:
            frozen(self, name, value)

    cls.__setattr__ = __setattr__
    return cls


def quantity(unit: str, symbol: str = "", description: str = "", display: str = "", *, source: str = "",
             headline: int = 0, beside: str | None = None, optional: bool = False, key: str | None = None):
    """A field holding a number (an array, a list of numbers) of results.json, in the SI unit ``unit``.

    Parameters
    ----------
    unit, symbol, description, display, source, beside
        As :class:`~autobal.analysis.run.quantities.Quantity`.
    headline : int
        0: not a headline number; else its place among the headline numbers (1 first).
    optional : bool
        The analysis may not compute it: default None, and then not in results.json.
    key : str, optional
        Its key in results.json where that is not the field's name (a name the Result's API uses otherwise).
    """
    meta = {QUANTITY: (unit, symbol, description, display, source, headline, beside)} | ({KEY: key} if key else {})
    if optional:
        return field(default=None, metadata=meta | {OMIT: True})
    return field(metadata=meta)


def shared(unit: str, symbol: str = "", description: str = "", display: str = "", *, source: str = "",
           beside: str | None = None):
    """A declaration several fields share (their key paths are joined into one Quantity): ``q = shared("1", "u0",
    "face-gap ratio")``, then ``u0: float = q()`` in each record, ``q(headline=1)``, ``q(optional=True)``."""
    return functools.partial(quantity, unit, symbol, description, display, source=source, beside=beside)


def keyed(key: str, kw_only=dataclasses.MISSING):
    """A field whose key in results.json is ``key``, not its name (a name the Result's API uses otherwise);
    ``kw_only`` as :func:`optional`."""
    return field(kw_only=kw_only, metadata={KEY: key})


def optional(kw_only=dataclasses.MISSING, key: str | None = None, present_with: str | None = None):
    """A field the analysis may not compute (a map, a scan): default None, and then not in results.json;
    ``kw_only``: keyword-only, for a field results.json has before fields without a default (unset: as the
    record's other fields, e.g. after a ``KW_ONLY`` marker); ``key`` as
    :func:`keyed`; with ``present_with``, the name of another field of the record, it is there (null) whenever
    that field is not None (the earliest arrival under a peak limit: none when the ramp keeps the limit, no key
    without a limit)."""
    return field(default=None, kw_only=kw_only, metadata={OMIT: present_with or True} | ({KEY: key} if key else {}))


def unsaved(default=None, default_factory=None):
    """A field the Result holds in memory only, not in its results.json block: what a figure of the run draws
    that the block does not hold (an IPOPT history, the scene's title, the re-simulations, samples its CSV tables
    list); ``from_dict`` gives it its default, and ``==`` does not compare it."""
    if default_factory is not None:
        return field(default_factory=default_factory, kw_only=True, repr=False, metadata={UNSAVED: True})
    return field(default=default, kw_only=True, repr=False, metadata={UNSAVED: True})


@record
class Record:
    """A block of results.json as a frozen dataclass (see the module's docstring).

    ``statuses`` says why a value is null: field key -> the ``<key>_status`` written beside it (:func:`explained`
    fills it in as :func:`~autobal.analysis.run.result.with_statuses` does for a dict)."""

    statuses: dict[str, str] = field(default_factory=dict, kw_only=True, repr=False, metadata={STATUSES: True})

    def to_dict(self) -> dict:
        """The block: the fields in order, records as their blocks, numbers as they are (arrays stay arrays); a
        null's ``<key>_status`` right after its key."""
        out = {}
        for f in _fields(self):
            v = getattr(self, f.name)
            omit = f.metadata.get(OMIT)
            if v is None and isinstance(omit, str):
                omit = getattr(self, omit) is None
            if f.metadata.get(UNSAVED) or v is None and omit or isinstance(v, Failures) and not v:
                continue
            out[_key(f)] = _out(v)
            if _key(f) in self.statuses:
                out[_key(f) + STATUS] = self.statuses[_key(f)]
        return out

    @classmethod
    def from_dict(cls, block: dict):
        """The record of a results.json block; KeyError naming the record and the key for a key it does not have
        or lacks (a renamed key is never read as missing)."""
        if not isinstance(block, dict):
            raise TypeError(f"{cls.__name__}: expected a mapping, got {type(block).__name__}")
        names = [_key(f) for f in _fields(cls)]
        statuses = {k.removesuffix(STATUS): v for k, v in block.items()
                    if k not in names and k.endswith(STATUS) and k.removesuffix(STATUS) in names}
        unknown = [k for k in block if k not in names and k.removesuffix(STATUS) not in statuses]
        if unknown:
            raise KeyError(f"{cls.__name__} has no field {', '.join(map(repr, unknown))}")
        hints = _hints(cls)
        kwargs = {"statuses": statuses} if statuses else {}
        for f in _fields(cls):
            if _key(f) in block:
                kwargs[f.name] = _in(hints[f.name], block[_key(f)])
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise KeyError(f"{cls.__name__}: the block has no {_key(f)!r}")
        return cls(**kwargs)

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and plain(self.to_dict()) == plain(other.to_dict())

    __hash__ = None


@record
class TypedResult(Record, Result):
    """Base of a typed Result: a :class:`Record` that is a :class:`~autobal.analysis.run.result.Result`, with its
    failures a field (:class:`~autobal.analysis.run.result.Failures`; in results.json only when there are some)."""

    failures: Failures = field(default=Failures(), kw_only=True)
    #: the key results.json has the failures after, written even when there are none (``[]``), for a Result whose
    #: block had them there before it was typed; None: first, and only when there are some
    failures_after: typing.ClassVar[str | None] = None
    #: key -> why its value may be null; when set, ``to_dict()`` writes a ``<key>_status`` beside every null of the
    #: block (:func:`~autobal.analysis.run.result.with_statuses`; ``from_dict()`` keeps them in ``statuses``)
    null_reasons: typing.ClassVar[dict | None] = None

    def __post_init__(self):
        object.__setattr__(self, "failures", Failures(self.failures))

    def to_dict(self) -> dict:
        out = super().to_dict()
        if self.null_reasons is not None:
            out = with_statuses(out, self.null_reasons)
        if self.failures_after is None:
            return out
        out.pop("failures", None)
        items = list(out.items())
        at = [k for k, _ in items].index(self.failures_after) + 1
        return dict(items[:at] + [("failures", list(self.failures))] + items[at:])

    @classmethod
    def from_folder(cls, block: dict, folder=None):
        """The Result of its results.json block and of the files its run wrote in ``folder`` (None: the block
        alone): a Result whose unsaved fields its files hold reads them here (``autobal.load_run``, the report)."""
        return cls.from_dict(block)


def _out(v):
    if isinstance(v, Record):
        return v.to_dict()
    if isinstance(v, dict):
        return {k: _out(x) for k, x in v.items()}
    if isinstance(v, Failures):
        return list(v)
    if isinstance(v, list) and any(isinstance(x, Record) for x in v):
        return [_out(x) for x in v]
    return v


def _key(f: dataclasses.Field) -> str:
    return f.metadata.get(KEY, f.name)


def _fields(rec) -> list[dataclasses.Field]:
    """The fields of a record (type) that are keys of its block (not its statuses, not an unsaved field)."""
    return [f for f in dataclasses.fields(rec) if not (f.metadata.get(STATUSES) or f.metadata.get(UNSAVED))]


def field_key(rec, name: str) -> str:
    """The results.json key of the field ``name`` of a record (type); KeyError naming the record for a name it
    has no field of (a renamed field fails at once, not as a missing row)."""
    for f in _fields(rec):
        if f.name == name:
            return _key(f)
    cls = rec if isinstance(rec, type) else type(rec)
    raise KeyError(f"{cls.__name__} has no field {name!r}")


def place(root: Record, rec: Record) -> str:
    """The key path of the record ``rec`` within ``root``, found by identity: '' for ``root`` itself, else the
    path ending in '.' (``reference.``, ``models.exact.``, ``peaks.0.``); ValueError if ``root`` does not hold it."""
    path = _place(root, rec)
    if path is None:
        raise ValueError(f"{type(root).__name__} does not hold this {type(rec).__name__}")
    return path


def _place(root: Record, rec: Record) -> str | None:
    if rec is root:
        return ""
    for f in _fields(root):
        v = getattr(root, f.name)
        items = v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) else [(None, v)]
        for k, x in items:
            inner = _place(x, rec) if isinstance(x, Record) else None
            if inner is not None:
                return f"{_key(f)}." + ("" if k is None else f"{k}.") + inner
    return None


def explained(rec: Record, reasons: dict | None = None, default: str = "no value here (NaN)") -> Record:
    """``rec`` with a status beside every number that is or holds NaN or None (null in results.json), nested
    records and blocks alike, as :func:`~autobal.analysis.run.result.with_statuses` does for a dict: the status is
    ``reasons[key]``, else the record's own non-empty ``reason``, else ``default``; a status already given, or a
    field of its own (``<key>_status``), is kept."""
    reasons = reasons or {}
    own = getattr(rec, "reason", None) if isinstance(getattr(rec, "reason", None), str) else None
    names, statuses, changes = [_key(f) for f in _fields(rec)], dict(rec.statuses), {}
    for f in _fields(rec):
        v, key = getattr(rec, f.name), _key(f)
        if isinstance(v, Record):
            changes[f.name] = explained(v, reasons, default)
        elif isinstance(v, dict) and v and all(isinstance(x, Record) for x in v.values()):
            changes[f.name] = {k: explained(x, reasons, default) for k, x in v.items()}
        elif isinstance(v, list) and v and all(isinstance(x, Record) for x in v):
            changes[f.name] = [explained(x, reasons, default) for x in v]
        elif isinstance(v, dict):
            changes[f.name] = with_statuses(v, reasons, default)
        elif (v is None and f.metadata.get(OMIT) or isinstance(v, str | bool | Failures) or key in statuses
              or key + STATUS in names):
            continue
        else:
            try:
                values = np.asarray(np.nan if v is None else v, float)
            except (TypeError, ValueError):
                continue
            if not np.all(np.isfinite(values)):
                statuses[key] = reasons.get(key) or own or default
    return dataclasses.replace(rec, **changes, statuses=statuses)


def _hints(cls) -> dict:
    return typing.get_type_hints(cls)


def _optional(tp):
    """``X | None`` -> X; other types as they are."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return args[0] if len(args) == 1 else tp
    return tp


def _in(tp, v):
    """A value of results.json as the field of type ``tp`` holds it."""
    tp = _optional(tp)
    if v is None:
        return None
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, Record):
        return tp.from_dict(v)
    if tp is np.ndarray:
        return np.asarray(v, float)  # null -> NaN, as computed
    if tp is Failures:
        return Failures(v)
    if origin is dict and len(typing.get_args(tp)) == 2:
        return {k: _in(typing.get_args(tp)[1], x) for k, x in v.items()}
    if origin is list and typing.get_args(tp):
        return [_in(typing.get_args(tp)[0], x) for x in v]
    return v


def _walk(cls, prefix: str = ""):
    """(key path, field) of every field of a record type, nested records walked (``*``: a mapping's names,
    ``[]``: list items)."""
    hints = _hints(cls)
    for f in _fields(cls):
        path, tp = prefix + _key(f), _optional(hints[f.name])
        yield path, f
        inner, sep = tp, "."
        if typing.get_origin(tp) is dict and len(typing.get_args(tp)) == 2:
            inner, sep = typing.get_args(tp)[1], ".*."
        elif typing.get_origin(tp) is list and typing.get_args(tp):
            inner, sep = typing.get_args(tp)[0], "[]."
        if isinstance(inner, type) and issubclass(inner, Record):
            yield from _walk(inner, path + sep)


def key_paths(cls) -> list[str]:
    """The key path of every field of a record type that holds a declared number."""
    return [path for path, f in _walk(cls) if QUANTITY in f.metadata]


def declarations(cls, *extra: Quantity, resolve=None) -> Declarations:
    """The Declarations of a typed Result: one :class:`Quantity` per declaration of its fields (the key paths of
    equal declarations joined), the headline ones first in their order, then ``extra`` (the blocks whose keys are
    names); ``resolve`` as :class:`Declarations`."""
    clash = [f.name for f in dataclasses.fields(cls) if f.name != "failures" and hasattr(Result, f.name)]
    if clash:
        raise TypeError(f"{cls.__name__}: field(s) {', '.join(clash)} would hide Result's own; name them otherwise "
                        "and give their results.json key with keyed()")
    paths: dict[tuple, list[str]] = {}
    for path, f in _walk(cls):
        if QUANTITY in f.metadata:
            paths.setdefault(f.metadata[QUANTITY], []).append(path)
    specs = sorted(paths, key=lambda s: (s[5] == 0, s[5]))  # headline by rank, then the rest in field order
    own = [Quantity(" ".join(paths[s]), s[0], s[1], s[2], s[3], source=s[4], headline=bool(s[5]), beside=s[6])
           for s in specs]
    return Declarations(*own, *extra, resolve=resolve)
