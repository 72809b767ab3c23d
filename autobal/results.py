"""Result writing: results.json with plain numbers (NaN written as null), CSV tables."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np


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


def write_json(path: Path, data: dict) -> None:
    path.write_text(json.dumps(plain(data), indent=2, allow_nan=False) + "\n")


def write_csv(path: Path, columns: dict) -> None:
    """One column per key, all of equal length; numbers written with full precision."""
    names = list(columns)
    rows = zip(*[np.asarray(columns[n]).tolist() for n in names], strict=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        w.writerows(rows)


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Lay out, write as PNG and close a matplotlib figure; returns ``path``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
