"""Run every benchmark of the project in one process and write benchmarks/RESULTS.md.

Each module ``benchmarks/<name>.py`` with a ``main()`` that returns its Markdown table is a
benchmark; ``python -m benchmarks`` runs them all (``python -m benchmarks NAME ...`` runs some).
"""

from __future__ import annotations

import importlib
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).parent


def machine() -> str:
    mem = ""
    try:
        kb = int(next(line for line in open("/proc/meminfo") if line.startswith("MemTotal")).split()[1])
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, StopIteration, ValueError):
        pass
    cpu = platform.processor() or ""
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    import casadi

    return (f"{platform.system()} {platform.machine()}, {cpu or 'cpu'}, {os.cpu_count()} cores{mem}; "
            f"Python {platform.python_version()}, CasADi {casadi.__version__}")


def main(names: list[str]) -> int:
    found = sorted(p.stem for p in HERE.glob("*.py") if not p.stem.startswith("_"))
    todo = names or found
    unknown = sorted(set(todo) - set(found))
    if unknown:
        print(f"unknown benchmark(s): {', '.join(unknown)}; available: {', '.join(found)}", file=sys.stderr)
        return 2
    parts = ["# Benchmark results", "", f"Machine: {machine()}.", "",
             "Each section: autobal against a peer solving the same problem in the same run; "
             "ratios are peer time / autobal time at matched accuracy.", ""]
    for name in todo:
        t0 = time.perf_counter()
        text = importlib.import_module(f"benchmarks.{name}").main()
        parts += [text.strip().replace("\n# ", "\n## ", 1).replace("# ", "## ", 1), "",
                  f"(benchmark wall time {time.perf_counter() - t0:.1f} s)", ""]
        print(f"{name}: done in {time.perf_counter() - t0:.1f} s")
    (HERE / "RESULTS.md").write_text("\n".join(parts))
    print(f"written: {HERE / 'RESULTS.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
