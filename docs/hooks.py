"""MkDocs hooks of the autobal site (``hooks:`` in mkdocs.yml).

* ``<!-- scenario-schema -->`` in a page is replaced by the scenario schema reference, generated from
  the pydantic models of :mod:`autobal.scenario`: every key with its type, SI unit, constraints, default
  and the ``Field`` description (the unit of a quantity is read from its type when a field has no
  description yet).
* ``build/griffe/autobal`` is laid out as the installed package (``models/`` at ``autobal/models`` and so
  on, the ``package-dir`` mapping of pyproject.toml, as symbolic links) so that mkdocstrings reads the
  sources of ``autobal.models``, ``autobal.analysis`` and ``autobal.ocp`` statically.
* ``<!-- quantities: ANALYSIS -->`` is replaced by the table of the declared quantities of an analysis
  (``autobal.report.DECLARED``): key, symbol, SI unit, display unit, meaning and source, the one copy that
  results.json ``units``, the report and the terminal use too.
* ``<!-- include: PATH -->`` is replaced by the text of PATH (relative to the repository root) with its
  headings moved one level down, so generated benchmark reports appear inside a page.
* Mathematics: ``$...$`` and ``$$...$$`` (kept apart from Markdown by ``pymdownx.arithmatex`` in generic
  mode) are converted to MathML when the page is built (``latex2mathml``), which browsers render without
  a script; ``\\tag{2.15}`` in a display equation becomes the source's equation number at its right.
"""

from __future__ import annotations

import html
import re
import shutil
import types
import typing
from pathlib import Path

import annotated_types
from mkdocs.plugins import event_priority
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

ROOT = Path(__file__).resolve().parents[1]


def package_dirs() -> dict[str, str]:
    """autobal.<name> -> folder, from the ``package-dir`` mapping of pyproject.toml."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        return {"models": "models", "analysis": "analysis", "ocp": "ocp", "scenarios": "scenarios"}
    mapping = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    return {name.split(".")[1]: folder for name, folder in mapping.items() if name.count(".") == 1}
INCLUDE = re.compile(r"<!--\s*include:\s*(\S+)\s*-->")
QUANTITIES = re.compile(r"<!--\s*quantities:\s*(\w+)\s*-->")
SCHEMA = "<!-- scenario-schema -->"


# ----------------------------------------------------------------------------- quantity units
def _kinds() -> dict:
    try:
        from autobal.units import DIMENSIONS
    except ImportError:  # the units module changed: fall back to "quantity"
        return {}
    return DIMENSIONS


def _quantity_kind(metadata) -> str | None:
    """The quantity kind ("length", "pressure", ...) of a field validated by autobal.units.quantity."""
    kinds = _kinds()
    for item in metadata:  # declared: json_schema_extra={"kind": ...}
        if isinstance(item, Extra) and item.get("kind") in kinds:
            return item["kind"]
    for item in metadata:
        func = getattr(item, "func", None)
        if func is None or type(item).__name__ != "BeforeValidator":
            continue
        for cell in getattr(func, "__closure__", None) or ():  # quantity(kind) closes over kind
            value = cell.cell_contents
            if isinstance(value, str) and value in kinds:
                return value
        for kind, entry in kinds.items():  # otherwise: the kind whose example it accepts
            try:
                func(entry[2])
            except Exception:  # noqa: BLE001 - any refusal means "not this kind"
                continue
            return kind
        return "quantity"
    return None


def _unit(kind: str) -> str:
    entry = _kinds().get(kind)
    if entry is None:
        return ""
    si = entry[1].replace("**", "^")
    return f"{si} (e.g. `{entry[2]}`)"


def _number(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _constraints(metadata) -> str:
    out = []
    names = {"gt": ">", "ge": "≥", "lt": "<", "le": "≤", "min_length": "length ≥", "max_length": "length ≤"}
    for item in metadata:
        if isinstance(item, Description | Extra):
            continue
        for attr, sym in names.items():
            value = getattr(item, attr, None)
            if value is not None and not callable(value):
                out.append(f"{sym} {_number(value)}")
        if isinstance(item, annotated_types.MultipleOf):
            out.append(f"multiple of {item.multiple_of}")
        pattern = getattr(item, "pattern", None)
        if isinstance(pattern, str):
            out.append(f"matches `{pattern}`")
        if type(item).__name__ == "AfterValidator":  # the sign of a quantity (autobal.units.quantity)
            words = [getattr(item.func, "__qualname__", "")]
            words += [c.cell_contents for c in getattr(item.func, "__closure__", None) or ()
                      if isinstance(c.cell_contents, str)]
            if "nonnegative" in " ".join(words):
                out.append("≥ 0")
            elif "positive" in " ".join(words):
                out.append("> 0")
    return ", ".join(dict.fromkeys(out))


# ----------------------------------------------------------------------------- type description
class Description(str):
    """A description found on an inner ``Annotated[..., Field(description=...)]`` of a field's type."""


class Extra(dict):
    """The ``json_schema_extra`` of a field or of an inner ``Annotated[..., Field(...)]``."""


def _strip_annotated(tp, metadata: list):
    while typing.get_origin(tp) is typing.Annotated:
        args = typing.get_args(tp)
        metadata.extend(args[1:])
        for extra in args[1:]:
            if isinstance(extra, FieldInfo):
                metadata.extend(extra.metadata)
                if extra.description:
                    metadata.append(Description(extra.description))
                if isinstance(extra.json_schema_extra, dict):
                    metadata.append(Extra(extra.json_schema_extra))
        tp = args[0]
    return tp


def _describe(tp, metadata: list, sections: list, path: str) -> tuple[str, str]:
    """(type text, unit text) of an annotation; models met on the way are queued in ``sections``."""
    tp = _strip_annotated(tp, metadata)
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        parts = [a for a in typing.get_args(tp) if a is not type(None)]
        described = [_describe(a, metadata, sections, path) for a in parts]
        return " or ".join(d[0] for d in described), " or ".join(dict.fromkeys(d[1] for d in described if d[1]))
    if origin is typing.Literal:
        return "one of " + ", ".join(f"`{a}`" for a in typing.get_args(tp)), ""
    if origin is list or origin is tuple:
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        inner, unit = _describe(args[0], [], sections, path + "[]") if args else ("value", "")
        return f"list of {inner}", unit
    if origin is dict:
        _, value = typing.get_args(tp)
        inner, unit = _describe(value, [], sections, path + ".<name>")
        return f"mapping of name to {inner}", unit
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        sections.append((path, tp))
        return f"section [`{path}`](#{_anchor(path)})", ""
    kind = _quantity_kind(metadata)
    if kind is not None:
        return f"{kind}", _unit(kind)
    name = {float: "number", int: "integer", bool: "true/false", str: "text"}.get(tp, getattr(tp, "__name__", str(tp)))
    return name, ""


def _anchor(path: str) -> str:
    return "s-" + re.sub(r"[^a-z0-9]+", "-", path.lower()).strip("-")


def _default(field: FieldInfo) -> str:
    if field.is_required():
        return "**required**"
    if field.default_factory is not None:
        try:
            value = field.default_factory()
        except TypeError:
            return "(computed)"
    else:
        value = field.default
    if value is None or value is PydanticUndefined:
        return "optional"
    if isinstance(value, BaseModel):
        return "(its defaults)"
    return f"`{value!r}`" if isinstance(value, str) else f"`{value}`"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _section(path: str, model: type[BaseModel], queue: list) -> str:
    doc = (model.__doc__ or "").strip()
    if doc.startswith(("A base class", "Usage docs")):  # pydantic's own BaseModel docstring
        doc = ""
    lines = [f'### `{path}` {{#{_anchor(path)}}}', ""]
    if doc:
        lines += [" ".join(doc.split("\n\n")[0].split()), ""]
    lines += ["| key | type | unit (SI) / constraint | default | meaning |", "|---|---|---|---|---|"]
    for name, field in model.model_fields.items():
        metadata = list(field.metadata)
        if isinstance(field.json_schema_extra, dict):
            metadata.append(Extra(field.json_schema_extra))
        typ, unit = _describe(field.annotation, metadata, queue, f"{path}.{name}" if path else name)
        limits = _constraints(metadata)
        unit_text = "; ".join(t for t in (unit, limits) if t)
        inner = [m for m in metadata if isinstance(m, Description)]
        description = field.description or (inner[0] if inner else "")
        lines.append(f"| `{name}` | {_cell(typ)} | {_cell(unit_text)} | {_cell(_default(field))} | "
                     f"{_cell(description)} |")
    return "\n".join(lines) + "\n"


def schema_markdown() -> str:
    """The scenario schema reference: one table per section, from the top level down."""
    from autobal.scenario import Scenario

    out: list[str] = []

    def visit(path: str, model: type[BaseModel]) -> None:  # depth first: a part's sections stay together
        children: list = []
        out.append(_section(path, model, children))
        for child_path, child in children:
            visit(child_path, child)

    visit("", Scenario)
    out[0] = out[0].replace("### `` {#s-}", "### Top level {#s-top}")
    return "\n".join(out)


# ----------------------------------------------------------------------------- package tree for griffe
def package_tree(target: Path = ROOT / "build" / "griffe") -> Path:
    """Lay out ``target/autobal`` as the installed package, by symbolic links into the repository."""
    pkg = target / "autobal"
    if pkg.exists():
        shutil.rmtree(pkg)
    pkg.mkdir(parents=True)
    for item in (ROOT / "autobal").iterdir():
        if item.name != "__pycache__":
            (pkg / item.name).symlink_to(item)
    for sub, folder in package_dirs().items():
        (pkg / sub).symlink_to(ROOT / folder, target_is_directory=True)
    return target


@event_priority(100)  # before mkdocstrings reads its paths
def on_config(config):
    package_tree()
    return config


# ----------------------------------------------------------------------------- includes
def _include(match: re.Match) -> str:
    text = (ROOT / match.group(1)).read_text(encoding="utf-8")
    return re.sub(r"^(#{1,5}) ", lambda m: "#" + m.group(1) + " ", text, flags=re.M)


def quantities_markdown(analysis: str) -> str:
    """The declared quantities of an analysis as a Markdown table."""
    from autobal import report

    decl = report.declarations(analysis)
    if decl is None:
        raise ValueError(f"<!-- quantities: {analysis} -->: the analysis declares no quantities (report.UNDECLARED)")
    lines = ["| key | symbol | SI unit | shown in | meaning | source |", "|---|---|---|---|---|---|"]
    for q in decl:
        keys = ", ".join(f"`{k}`" for k in q.keys)
        lines.append(f"| {_cell(keys)} | {_cell(q.symbol)} | {_cell(q.unit)} | {_cell(q.display)} | "
                     f"{_cell(q.description)} | {_cell(q.source)} |")
    return "\n".join(lines) + "\n"


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs hook signature
    if SCHEMA in markdown:
        markdown = markdown.replace(SCHEMA, schema_markdown())
    markdown = QUANTITIES.sub(lambda m: quantities_markdown(m.group(1)), markdown)
    return INCLUDE.sub(_include, markdown)


# ----------------------------------------------------------------------------- mathematics
MATH = re.compile(r'<(span|div) class="arithmatex">(.*?)</\1>', re.S)
TAG = re.compile(r"\\tag\{([^{}]*)\}")


def math_html(tex: str, display: bool) -> str:
    """MathML of one TeX formula; a display formula's ``\\tag{N}`` becomes the number (N) at its right."""
    from latex2mathml.converter import convert

    tags = TAG.findall(tex)
    if len(tags) > 1:
        raise ValueError(f"more than one \\tag in a formula: {tex!r}")
    tex = TAG.sub("", tex).strip()
    try:
        mathml = convert(tex, display="block" if display else "inline")
    except Exception as exc:  # noqa: BLE001 - latex2mathml raises its own types; name the formula
        raise ValueError(f"latex2mathml cannot convert {tex!r}: {exc}") from exc
    if "<mi>&</mi>" in mathml or "<mi>\\</mi>" in mathml:  # e.g. an aligned environment it does not know
        raise ValueError(f"latex2mathml cannot align {tex!r}: use array{{rl}} or cases")
    if re.search(r"\\\\\[[^]]*\]", tex):  # \\[6pt] would be printed as "[6pt]"
        raise ValueError(f"latex2mathml takes no row spacing \\\\[..] in {tex!r}")
    if not display:
        return mathml
    number = f'<span class="eqno">({html.escape(tags[0])})</span>' if tags else ""
    return f'<div class="equation">{mathml}{number}</div>'


def _math(match: re.Match) -> str:
    text = html.unescape(match.group(2)).strip()
    display = match.group(1) == "div"
    for start, end in ((r"\[", r"\]"), (r"\(", r"\)"), ("$$", "$$"), ("$", "$")):
        if text.startswith(start) and text.endswith(end):
            text = text[len(start):len(text) - len(end)]
            break
    return math_html(text, display)


def on_page_content(html_text: str, page, config, files) -> str:  # noqa: ARG001 - MkDocs hook signature
    try:
        return MATH.sub(_math, html_text)
    except ValueError as exc:
        raise ValueError(f"{page.file.src_uri}: {exc}") from exc
