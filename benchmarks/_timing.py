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


def cpu_best_of(n: int, fn) -> float:
    """The shortest CPU time of ``n`` calls of ``fn()`` (this process, all threads), s: less disturbed than the
    wall time by other processes on a shared machine."""
    best = float("inf")
    for _ in range(n):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best
