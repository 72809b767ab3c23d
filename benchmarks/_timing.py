"""Timing shared by the benchmarks."""

from __future__ import annotations

import time


def best_of(n: int, fn):
    """The shortest wall time of ``n`` calls of ``fn()`` and the result of the last call."""
    best, out = float("inf"), None
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out
