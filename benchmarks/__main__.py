"""Run the benchmarks of the project and write benchmarks/RESULTS.md from benchmarks/results/*.json.

Each module ``benchmarks/<name>.py`` with a ``main()`` is a benchmark; it writes
``benchmarks/results/<name>.json`` through :mod:`benchmarks._results`.  ``python -m benchmarks``
runs them all, ``python -m benchmarks NAME ...`` runs some; ``python -m benchmarks --render`` only
regenerates RESULTS.md from the JSON files already there.
"""

from __future__ import annotations

import importlib
import sys
import time

from benchmarks._results import HERE, render


def main(names: list[str]) -> int:
    found = sorted(p.stem for p in HERE.glob("*.py") if not p.stem.startswith("_"))
    if names == ["--render"]:
        names = todo = []
    else:
        todo = names or found
    unknown = sorted(set(todo) - set(found))
    if unknown:
        print(f"unknown benchmark(s): {', '.join(unknown)}; available: {', '.join(found)}", file=sys.stderr)
        return 2
    for name in todo:
        t0 = time.perf_counter()
        importlib.import_module(f"benchmarks.{name}").main()
        print(f"{name}: done in {time.perf_counter() - t0:.1f} s")
    (HERE / "RESULTS.md").write_text(render())
    print(f"written: {HERE / 'RESULTS.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
