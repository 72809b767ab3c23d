"""Command line: ``autobal run|check|list``.

Exit codes: 0 success, 2 bad input (one line naming the field), 3 failed solve (solver status
printed, last iterate written to DIR/failed_solve.json).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from autobal import scenario
from autobal.errors import ScenarioError, SolveError
from autobal.results import write_json

EXIT_BAD_INPUT, EXIT_SOLVE_FAILED = 2, 3


def run(scn: scenario.Scenario, out: Path) -> dict:
    """Run every analysis the scene names; write results.json, CSV tables and PNG figures."""
    from autobal.pipeline import RUNNERS, runner

    out.mkdir(parents=True, exist_ok=True)
    results = {"scenario": scn.name, "title": scn.title, "source": scn.source, "files": []}
    for name in RUNNERS:
        settings = getattr(scn.analyses, name, None)
        if settings is not None:
            block, files, summary = runner(name)(scn, settings, out)
            results[name] = block
            results["files"] += [f.name for f in files]
            print(summary)
    write_json(out / "results.json", results)
    return results


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="autobal", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p_run = sub.add_parser("run", help="run the analyses a scenario names")
    p_run.add_argument("scenario", help="a YAML file, or the name of a shipped scenario")
    p_run.add_argument("--out", type=Path, default=None, help="output folder (default out/<scenario>)")
    p_check = sub.add_parser("check", help="validate a scenario without solving")
    p_check.add_argument("scenario")
    sub.add_parser("list", help="list the shipped scenarios")
    args = ap.parse_args(argv)

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
            run(scn, out)
        except SolveError as exc:
            out.mkdir(parents=True, exist_ok=True)
            write_json(out / "failed_solve.json", {"error": str(exc), "status": exc.status,
                                                   "last_iterate": exc.last_iterate})
            print(f"autobal: solve failed: {exc}; last iterate in {out / 'failed_solve.json'}",
                  file=sys.stderr)
            return EXIT_SOLVE_FAILED
        print(f"results: {out / 'results.json'}")
        return 0
    except ScenarioError as exc:
        print(f"autobal: bad input: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
