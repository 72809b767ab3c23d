"""Until every analysis returns a Result (autobal.analysis.result), its old writers live here."""

from __future__ import annotations

from pathlib import Path

from autobal.analysis.result import plain, write_csv, write_json  # noqa: F401 (re-exported)


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Lay out, write as PNG and close a pyplot figure; returns ``path``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
