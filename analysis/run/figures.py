"""A figure of a Result with its caption and the quantity on each of its axes.

``Result.figures()`` returns file name -> :class:`Figure`: the matplotlib figure, one sentence saying what is drawn
(citing the source's figure where it reproduces one), which ``Result.save`` writes to results.json ``captions`` and
report.html shows under the figure, and the quantities of its axes as :func:`~autobal.analysis.run.result.unit_axis`
labelled them (the display unit shown, so a test can check that an axis in µm says µm).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure as MplFigure


@dataclasses.dataclass(frozen=True)
class Axis:
    """The quantity on one axis: its label as drawn, which axis ("x" or "y"), its SI unit and the unit shown."""

    label: str
    which: str
    si: str
    shown: str


def record_axis(ax: Axes, which: str, si: str, shown: str) -> None:
    """Keep on ``ax`` the quantity its ``which`` axis shows (called by ``unit_axis``)."""
    ax.__dict__.setdefault("autobal_axes", {})[which] = (si, shown)


@dataclasses.dataclass(frozen=True, eq=False)
class Figure:
    """A figure of a Result: the matplotlib figure and its caption; attributes of the matplotlib figure
    (``axes``, ``savefig``) are read through it."""

    figure: MplFigure
    caption: str

    def __post_init__(self):
        if not isinstance(self.caption, str) or not self.caption.strip():
            raise ValueError("a figure needs a caption: one sentence saying what is drawn")

    @property
    def quantities(self) -> list[Axis]:
        """The quantity of each axis labelled by ``unit_axis`` or :func:`record_axis` (an axis of a dimensionless group
        has none; one whose label was taken off, as the upper of two axes sharing x, is left out)."""
        out = []
        for ax in self.figure.axes:
            for which, (si, shown) in ax.__dict__.get("autobal_axes", {}).items():
                label = ax.get_xlabel() if which == "x" else ax.get_ylabel()
                out += [Axis(label, which, si, shown)] if label else []
        return out

    def __getattr__(self, name):
        if name.startswith("__") or name in ("figure", "caption"):
            raise AttributeError(name)
        return getattr(self.figure, name)
