"""Command line: ``autobal run|accuracy|check|list``.

Exit codes: 0 success, 2 bad input (one line naming the field), 3 failed solve (solver status
printed, last iterate written to DIR/failed_solve.json).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from autobal import scenario
from autobal.errors import ScenarioError, SolveError
from autobal.results import write_json

EXIT_BAD_INPUT, EXIT_SOLVE_FAILED = 2, 3


def run(scn: scenario.Scenario, out: Path) -> dict:
    """Run every analysis the scene names; write results.json, CSV tables and PNG figures."""
    from autobal.pipeline import RUNNERS, runner

    out.mkdir(parents=True, exist_ok=True)
    results = {"scenario": scn.name, "title": scn.title, "source": scn.source, "files": [], "timing": {},
               "accuracy": {}}
    for name in RUNNERS:
        settings = getattr(scn.analyses, name, None)
        if settings is not None:
            t0 = time.perf_counter()
            block, files, summary = runner(name)(scn, settings, out)
            results["timing"][name] = time.perf_counter() - t0
            results["accuracy"][name] = block.get("accuracy", {"estimate": None,
                                                              "how": "this analysis reports no error estimate"})
            results[name] = block
            results["files"] += [f.name for f in files]
            print(summary)
    write_json(out / "results.json", results)
    return results


def accuracy(scn: scenario.Scenario, out: Path) -> dict:
    """Work-precision of every analysis of the scene that has a provider: figure, CSV, summary."""
    from autobal.analysis.workprecision import PROVIDERS
    from autobal.pipeline import resolve

    out.mkdir(parents=True, exist_ok=True)
    report = {"scenario": scn.name, "studies": {}, "files": []}
    for name, target in PROVIDERS.items():
        settings = getattr(scn.analyses, name, None)
        if settings is None:
            continue
        wp = resolve(target)(scn, settings)
        report["studies"][name] = wp.to_dict()
        report["files"] += [f.name for f in wp.write_tables(out) + wp.plot(out)]
        print(wp.summary())
    if not report["studies"]:
        raise ScenarioError(f"{scn.name}: none of its analyses has a work-precision study "
                            f"(available: {', '.join(PROVIDERS)})")
    write_json(out / "accuracy.json", report)
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="autobal", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p_run = sub.add_parser("run", help="run the analyses a scenario names")
    p_run.add_argument("scenario", help="a YAML file, or the name of a shipped scenario")
    p_run.add_argument("--out", type=Path, default=None, help="output folder (default out/<scenario>)")
    p_run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run sweeps and Monte Carlo on this dask.distributed scheduler (e.g. tcp://host:8786)")
    p_acc = sub.add_parser("accuracy", help="error against run time of every solver of a scenario")
    p_acc.add_argument("scenario")
    p_acc.add_argument("--out", type=Path, default=None, help="output folder (default out/<scenario>)")
    p_check = sub.add_parser("check", help="validate a scenario without solving")
    p_check.add_argument("scenario")
    sub.add_parser("list", help="list the shipped scenarios")
    args = ap.parse_args(argv)
    if args.cmd == "run":  # analysis/executor.py: the CLI's --scheduler overrides the scene's executor
        from autobal.analysis.executor import set_default_scheduler

        set_default_scheduler(args.scheduler)

    if args.cmd == "list":
        for p in scenario.shipped():
            s = scenario.load(p)
            print(f"{p.stem:32s} {s.title}")
        return 0
    try:
        scn = scenario.load(args.scenario)
        if args.cmd == "check":
            analyses = [k for k, v in scn.analyses if v is not None]
            print(f"{scn.name}: valid; analyses: {', '.join(analyses) or 'none'}")
            return 0
        out = args.out or Path("out") / scn.name
        try:
            (accuracy if args.cmd == "accuracy" else run)(scn, out)
        except SolveError as exc:
            out.mkdir(parents=True, exist_ok=True)
            write_json(out / "failed_solve.json", {"error": str(exc), "status": exc.status,
                                                   "last_iterate": exc.last_iterate})
            print(f"autobal: solve failed: {exc}; last iterate in {out / 'failed_solve.json'}",
                  file=sys.stderr)
            return EXIT_SOLVE_FAILED
        print(f"results: {out / ('accuracy.json' if args.cmd == 'accuracy' else 'results.json')}")
        return 0
    except ScenarioError as exc:
        print(f"autobal: bad input: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
