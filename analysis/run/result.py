"""The Result protocol every analysis returns, and the plain writers of its files.

A result is data first: ``to_dict()`` is its block of results.json, ``summary()`` a short text,
``tables()`` its CSV tables and ``figures()`` its matplotlib figures.  Figures are plain
:class:`matplotlib.figure.Figure` objects made by :func:`new_figure`, never through pyplot, so
plotting neither switches the caller's backend nor writes anything; ``save(folder)`` writes.
"""

from __future__ import annotations

import csv
import functools
import json
import math
from html import escape
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from autobal.analysis.run.figures import Figure as Captioned

DPI = 120


def plain(obj):
    """numpy scalars/arrays -> Python numbers/lists; NaN and infinities -> None (JSON null)."""
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer | int):
        return int(obj)
    if isinstance(obj, np.floating | float):
        return float(obj) if math.isfinite(obj) else None
    return obj


def write_json(path: Path, data: dict) -> Path:
    """Write ``data`` as indented JSON with :func:`plain` numbers; returns ``path``."""
    path.write_text(json.dumps(plain(data), indent=2, allow_nan=False) + "\n")
    return path


def write_csv(path: Path, columns: dict) -> Path:
    """One column per key, all of equal length, numbers at full precision; returns ``path``."""
    names = list(columns)
    rows = zip(*[np.asarray(columns[n]).tolist() for n in names], strict=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        w.writerows(rows)
    return path


def new_figure(figsize: tuple[float, float] = (6.4, 4.4), nrows: int = 1, ncols: int = 1, **subplots_kw):
    """A new :class:`~matplotlib.figure.Figure` and its axes, outside pyplot.

    Parameters
    ----------
    figsize : (float, float)
        Width and height, inches.
    nrows, ncols : int
        Grid of axes, as :meth:`matplotlib.figure.Figure.subplots`.
    **subplots_kw
        Passed to :meth:`~matplotlib.figure.Figure.subplots` (``sharex``, ``squeeze`` ...).

    Returns
    -------
    (Figure, Axes or array of Axes)
        The figure is not registered with pyplot: the caller's backend is untouched and nothing
        has to be closed.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, **subplots_kw)


def unit_axis(ax: Axes, label: str, si: str, declared: str = "", which: str = "y", other: str | None = None) -> float:
    """Label an axis of values of results.json unit ``si`` in their display unit: the unit chosen for its kind
    (:func:`~autobal.analysis.run.quantities.display_units`), else ``declared``, else the field's default; the unit
    ``other`` on a secondary axis (right, or top for ``which="x"``), by default the one shown beside it in the
    tables (rpm beside rad/s, rad/s beside rpm).  Returns the factor that takes SI values to the axis' unit:
    plot ``values * factor``.

    Parameters
    ----------
    ax : Axes
    label : str
        The quantity in words and symbol ("speed $\\omega$"); the unit is appended (", rpm").
    si : str
        The unit of the values in results.json ("rad/s", "m", "um").
    declared : str
        The declared display unit (a :class:`~autobal.analysis.run.quantities.Quantity`'s ``declared``).
    which : {"x", "y"}
    other : str, optional
        The unit of the secondary axis; "" for none.
    """
    from autobal.analysis.run.figures import record_axis
    from autobal.analysis.run.quantities import beside, convert, display_unit_of

    shown = display_unit_of(si, declared)
    factor = convert(1.0, si, shown)
    record_axis(ax, which, si, shown)
    (ax.set_xlabel if which == "x" else ax.set_ylabel)(label if shown == "1" else f"{label}, {shown}")
    other = beside(si, shown) if other is None or other == shown else other
    if other:
        twin_axis(ax, convert(1.0, si, other) / factor, other, which)
    return factor


def speed_axis(ax: Axes, which: str = "y", label: str = r"speed $\omega$") -> float:
    """A shaft-speed axis: rpm with rad/s beside unless a speed unit is chosen (:func:`unit_axis`); returns the
    factor from rad/s."""
    return unit_axis(ax, label, "rad/s", "rpm", which)


def twin_axis(ax: Axes, factor: float, label: str, which: str = "y") -> None:
    """A secondary axis (right, or top for ``which="x"``) showing the axis' values times ``factor``: rpm beside
    rad/s, Hz beside rad/s, a deflection beside delta/e."""
    functions = (lambda v: v * factor, lambda v: v / factor)
    if which == "x":
        ax.secondary_xaxis("top", functions=functions).set_xlabel(label)
    else:
        ax.secondary_yaxis("right", functions=functions).set_ylabel(label)


def fixed_layout(fig: Figure, left: float, right: float, top: float, bottom: float, hspace: float = 0.3) -> None:
    """Give ``fig`` margins fixed in inches instead of constrained layout, with the bottom margin grown by
    the height of the figure legends (placed ``"outside lower center"``), measured at each draw.

    Constrained layout measures every tick label, axis label and legend entry before each draw, which is
    most of the time a figure takes to draw; with fixed margins only the legend is measured (its text is
    laid out once, for the draw as well). For figures whose labels are known in advance.

    Parameters
    ----------
    fig : Figure
        A figure from :func:`new_figure`.
    left, right, top, bottom : float
        Margins, inches: room for the tick labels and axis labels on each side (and the suptitle on top).
    hspace : float
        Height of the space between rows of axes, as a fraction of the mean axes height.
    """
    from matplotlib.layout_engine import LayoutEngine

    class FixedLayout(LayoutEngine):
        _adjust_compatible = True
        _colorbar_gridspec = True

        def execute(self, fig) -> None:
            w, h = fig.get_size_inches()
            # the renderer of the draw (Agg for PNG; for SVG, whose canvas keeps none, matplotlib makes one)
            legends = sum(leg.get_window_extent().height for leg in fig.legends) / fig.dpi
            fig.subplots_adjust(left=left / w, right=1 - right / w, top=1 - top / h,
                                bottom=(bottom + legends) / h, hspace=hspace)

    fig.set_layout_engine(FixedLayout())


def save_figures(fig: Figure, path: Path, dpi: int = DPI) -> list[Path]:
    """Write a figure as PNG (``path`` with the suffix .png; report.html embeds it) and as SVG beside it, for
    documents: the one place a result's figures are saved.  Returns both paths.

    The SVG takes the layout the PNG's draw made (the margins, constrained layout's axes positions: in
    inches, the same at any resolution), so it is drawn once, without a layout pass of its own; that pass
    measures every label again and is about half the time of an SVG.
    """
    png = save_figure(fig, path.with_suffix(".png"), dpi)
    engine = fig.get_layout_engine()
    fig.set_layout_engine("none")  # keeps the positions the layout engine set for the PNG
    try:
        return [png, save_figure(fig, path.with_suffix(".svg"), dpi)]
    finally:
        fig.set_layout_engine(engine)


def save_figure(fig: Figure, path: Path, dpi: int = DPI) -> Path:
    """Write a figure as PNG (or the format of ``path``'s suffix); returns ``path``.

    A PNG is drawn once on an Agg canvas (``savefig`` first makes a layout pass with drawing disabled,
    then draws) and encoded at zlib level 1, which makes files of about the same size as level 6 in
    less time: 10-15 % less in all for the statics figures, the same pixels.

    Parameters
    ----------
    fig : Figure
        The figure (from :func:`new_figure`).
    path : Path
        The file to write; its suffix is the format.
    dpi : int
        Resolution, dots per inch.

    Returns
    -------
    Path
    """
    if path.suffix.lower() == ".svg":  # text kept as text (editable, searchable), the same bytes every run
        from matplotlib import rc_context

        with rc_context({"svg.fonttype": "none", "svg.hashsalt": "autobal"}):
            fig.savefig(path, format="svg", metadata={"Date": None})
        return path
    if path.suffix.lower() != ".png":
        fig.savefig(path, dpi=dpi)
        return path
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.image import imsave

    own_canvas, own_dpi = fig.canvas, fig.dpi
    try:
        fig.set_dpi(dpi)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        imsave(path, canvas.buffer_rgba(), format="png", dpi=dpi, pil_kwargs={"compress_level": 1})
    finally:  # the figure keeps its own canvas and resolution, as after savefig
        fig.set_canvas(own_canvas)
        fig.set_dpi(own_dpi)
    return path


def fmt(v, digits: int = 5) -> str:
    """A number for a summary table: ``digits`` significant digits, '-' for None/NaN."""
    if v is None or (isinstance(v, float | np.floating) and not np.isfinite(v)):
        return "-"
    return f"{v:.{digits}g}"


#: the methods of a Result that show numbers to a person, in display units: each runs in the display units of the
#: scene the result came from (:attr:`Result.display_choice`), under a caller's own ``display_units`` block
SHOWN = ("summary", "tables", "figures", "draw", "headline", "verdict")


def in_display_units(method):
    """``method`` of a Result, run in the display units of the result's scene (:attr:`Result.display_choice`):
    the kinds the caller chose (an enclosing :func:`~autobal.analysis.run.quantities.display_units`) keep the
    caller's unit."""
    if getattr(method, "in_display_units", False):
        return method

    @functools.wraps(method)
    def shown(self, *args, **kwargs):
        from autobal.analysis.run.quantities import display_units

        with display_units(self.display_choice, under=True):
            return method(self, *args, **kwargs)

    shown.in_display_units = True
    return shown


class Failures(tuple):
    """What failed inside an analysis, one line each (:attr:`Result.failures`); calling it gives the list."""

    def __call__(self) -> list[str]:
        return list(self)


class Result:
    """Base of every analysis result.

    Subclasses implement :meth:`to_dict` and :meth:`summary`, and usually :meth:`tables`,
    :meth:`figures` and :meth:`draw`.  Headline quantities are properties with their unit in
    the docstring.
    """

    #: the analysis key of results.json (``"statics"``, ``"frequency"`` ...)
    name: str = ""
    #: every number of :meth:`to_dict`, declared (:class:`~autobal.analysis.run.quantities.Declarations`); None: a
    #: result without headline numbers (its summary stands in the notebook view)
    quantities = None
    #: the display units of the scene this result was run from, kind -> unit (``autobal.run`` sets it from the
    #: scene's ``display`` section): :data:`SHOWN` methods show them wherever they are called
    display_choice: dict | None = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        for name in SHOWN:
            if name in cls.__dict__:
                setattr(cls, name, in_display_units(cls.__dict__[name]))

    def to_dict(self) -> dict:
        """The results.json block: plain numbers in SI or named dimensionless groups."""
        raise NotImplementedError

    def summary(self) -> str:
        """A short plain-text summary of the headline numbers."""
        raise NotImplementedError

    @property
    def failures(self) -> Failures:
        """What failed inside this analysis although it returned, one line each: a residual above the
        analysis' tolerance, an integrator failure, a case that did not finish.  Empty when everything it
        reports was solved.  A typed Result (analysis/run/fields.py) has them as its field ``failures``; a Result
        holding ``data`` records them as ``data["failures"]``.  A result with failures makes the run's status
        "failed" (:class:`autobal.api.Run`; the CLI exits with 3).  ``failures()`` gives them as a list."""
        return Failures(getattr(self, "data", {}).get("failures") or [])

    def tables(self) -> dict[str, dict]:
        """CSV tables: file name -> {column name: sequence of equal length}."""
        return {}

    def figures(self) -> dict[str, Captioned]:
        """Figures: file name -> :class:`~autobal.analysis.run.figures.Figure`, a new matplotlib figure (made with
        :func:`new_figure`) with its caption."""
        return {}

    def draw(self, ax: Axes) -> None:
        """Draw the headline plot onto the caller's axes."""
        raise NotImplementedError(f"{type(self).__name__} has no single-axes plot: call plot() without ax")

    def plot(self, ax: Axes | None = None):
        """The figures of this result.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Draw the headline plot onto these axes instead of making new figures.

        Returns
        -------
        list of Figure, or Figure
            Without ``ax``, every figure of :meth:`figures`; with ``ax``, ``ax.figure``.
        """
        if ax is None:
            return [f.figure for f in self.figures().values()]
        self.draw(ax)
        return ax.figure

    def save(self, folder: str | Path) -> list[Path]:
        """Write :meth:`tables` as CSV and :meth:`figures` as PNG with SVG beside into ``folder``; returns the
        paths."""
        return self.write(folder)[0]

    def write(self, folder: str | Path) -> tuple[list[Path], dict[str, str]]:
        """:meth:`save`, and the captions of the figures written: (paths, file name -> caption)."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = [write_csv(folder / name, cols) for name, cols in self.tables().items()]
        figures = self.figures()
        paths += [p for name, f in figures.items() for p in save_figures(f.figure, folder / name)]
        return paths, {name: f.caption for name, f in figures.items()}

    def verdict(self) -> tuple[bool | None, str] | None:
        """The one verdict of the analysis, (ok, words), where it has one (the headline model's)."""
        return None

    def headline(self) -> list[dict]:
        """The headline quantities as records (quantity, symbol, value and unit as displayed, the value in the unit
        shown beside it (rpm beside rad/s), SI value and unit, key), from the declarations of :attr:`quantities`;
        empty where the analysis declares none."""
        from autobal.analysis.run.quantities import significant

        if self.quantities is None:
            return []
        return [{"quantity": q.description, "symbol": q.symbol, "value": significant(q.shown(v)),
                 "unit": "" if q.display == "1" else q.display, "beside": q.also(v),
                 "si_value": v, "si_unit": q.unit, "key": key}
                for q, key, v in self.quantities.headline(self.to_dict())]

    def to_dataframe(self, table: str | None = None):
        """The CSV tables of :meth:`tables` as pandas DataFrames (pandas is optional: ``pip install pandas``).

        Parameters
        ----------
        table : str, optional
            One table's file name (``"statics_sweep.csv"``); without it, every table.

        Returns
        -------
        pandas.DataFrame, or dict of file name -> DataFrame
        """
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError("to_dataframe() needs pandas, which autobal does not install: pip install pandas "
                              "(or pip install 'autobal[notebook]'); tables() gives the same columns as dicts") from exc
        tables = self.tables()
        if table is not None:
            if table not in tables:
                raise KeyError(f"{type(self).__name__} has no table {table!r}; it has: {', '.join(tables) or 'none'}")
            return pd.DataFrame(tables[table])
        return {name: pd.DataFrame(cols) for name, cols in tables.items()}

    def _repr_html_(self) -> str:
        """Jupyter's view: the verdict, the headline numbers in display units (or the summary) and the figures."""
        return html_block(self)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name}>"


for _name in SHOWN:
    setattr(Result, _name, in_display_units(getattr(Result, _name)))


def html_verdict(verdict: tuple[bool | None, str] | None) -> str:
    """A verdict as an HTML paragraph: ✔ good, ✘ bad, • information."""
    if verdict is None:
        return ""
    ok, words = verdict
    mark, colour = {True: ("✔", "#1a7f37"), False: ("✘", "#c0392b")}.get(ok, ("•", "#555"))
    return f'<p style="color:{colour};font-weight:bold">{mark} {escape(words)}</p>'


def html_table(rows: list[dict], columns: tuple[str, ...] = ("quantity", "symbol", "value", "unit", "beside")) -> str:
    """Records as an HTML table of the named columns."""
    head = "".join(f"<th>{escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{escape(str(r.get(c, '')))}</td>" for c in columns) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def html_figure(fig: Figure, dpi: int = 80) -> str:
    """A figure as an inline PNG ``<img>`` (drawn off pyplot, the caller's backend untouched)."""
    import base64
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return f'<img style="max-width:100%" src="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}">'


def html_block(result: Result, figures: bool = True) -> str:
    """One result as HTML: its name, its verdict, its headline table in display units (the summary text
    where it declares no headline) and its figures."""
    rows = result.headline()
    body = html_table(rows) if rows else f"<pre>{escape(result.summary())}</pre>"
    figs = "".join(html_figure(f.figure) for f in result.figures().values()) if figures else ""
    verdict = (False, "FAILED: " + "; ".join(result.failures())) if result.failures() else result.verdict()
    return (f"<div><h3>{escape(result.name or type(result).__name__)}</h3>{html_verdict(verdict)}"
            f"{body}{figs}</div>")


def failed_head(failures: list[str]) -> list[str]:
    """The first line of a summary whose analysis has failures (:meth:`Result.failures`), else nothing."""
    return [f"FAILED: {'; '.join(failures)}"] if failures else []


def with_statuses(block: dict, reasons: dict | None = None, default: str = "no value here (NaN)") -> dict:
    """A copy of ``block`` with a ``<key>_status`` beside every value that is or holds NaN or None (null in
    results.json), so that no null goes unexplained.  The status is ``reasons[key]``, else the mapping's own
    non-empty ``reason``, else ``default``; nested mappings and lists of mappings are treated alike.

    Parameters
    ----------
    block : dict
        A results.json block.
    reasons : dict, optional
        Key -> why its value can be null.
    default : str
        The status where neither says why.

    Returns
    -------
    dict
    """
    reasons = reasons or {}
    own = block.get("reason") if isinstance(block.get("reason"), str) and block.get("reason") else None
    out = {}
    for k, v in block.items():
        if isinstance(v, dict):
            out[k] = with_statuses(v, reasons, default)
            continue
        if isinstance(v, list | tuple) and v and all(isinstance(x, dict) for x in v):
            out[k] = [with_statuses(x, reasons, default) for x in v]
            continue
        out[k] = v
        if isinstance(v, str | bool) or f"{k}_status" in block:
            continue
        try:
            values = np.asarray(np.nan if v is None else v, float)
        except (TypeError, ValueError):
            continue
        if not np.all(np.isfinite(values)):
            out[f"{k}_status"] = reasons.get(k) or own or default
    return out
