"""Command line of autobal: run the analyses of a scenario, check it, list the shipped ones."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from autobal import __version__, api, report, scenario, units
from autobal.analysis import progress
from autobal.errors import Interrupted, ScenarioError, SolveError
from autobal.output import LOG, OutputFolder, SolverLog
from autobal.schema import quantities

EXIT_OK, EXIT_BAD_INPUT, EXIT_SOLVE_FAILED = 0, 2, 3

EPILOG = """\
exit codes:
  0    success
  2    bad input: one line naming the file or override, the field and the unit
  3    failed solve: the solver status; its last iterate in OUT/failed_solve.json, or an
       analysis that finished with failures (a residual above its tolerance, an integrator
       failure): OUT/results.json with "status": "failed" and what failed under "failures"
  130  interrupted (Ctrl-C, SIGINT); OUT holds interrupted.json
  143  terminated (SIGTERM); OUT holds interrupted.json

Every run writes into a temporary folder beside OUT and moves it into place when it ends, so OUT
holds the files of exactly one run; what solvers print goes to OUT/autobal.log.
"""


def _overrides(pairs: list[str]) -> dict:
    out = {}
    for pair in pairs:
        path, sep, value = pair.partition("=")
        if not sep or not path.strip():
            raise ScenarioError(f"--set {pair}: write PATH=VALUE, e.g. device.disc.face.base_gap='0.18 mm'")
        out[path.strip()] = value.strip()
    return out


def _out_folder(args, scn) -> Path:
    return args.out if args.out is not None else Path("out") / scn.name


def _run(args, scn) -> int:
    out = _out_folder(args, scn)
    note = scenario.long_run_note(scn)
    if note and not args.quiet:
        print(note, flush=True)

    def show(name, result, seconds):
        if not args.quiet:
            print(result.summary())
            print(f"  ({name}: {seconds:.2f} s)")

    done = api.run(scn, out, on_result=show, scheduler=args.scheduler)
    if done.status != "ok":
        what = "; ".join(f"{name}: {f[0]}" + (f" (and {len(f) - 1} more)" if len(f) > 1 else "")
                         for name, f in done.failures.items())
        print(f"autobal: solve failed: {what}; the results, marked failed, in {out / 'results.json'}", file=sys.stderr)
        return EXIT_SOLVE_FAILED
    if not args.quiet:
        print(f"results: {out / 'results.json'}")
    return EXIT_OK


def _accuracy(args, scn) -> int:
    """Work-precision of every analysis of the scene that has a provider: figure, CSV, summary."""
    from autobal.analysis.result import write_json
    from autobal.runners import ACCURACY

    studies = {name: study for name, study in ACCURACY.items() if getattr(scn.analyses, name, None) is not None}
    if not studies:
        raise ScenarioError(f"{scn.name}: none of its analyses has a work-precision study "
                            f"(available: {', '.join(ACCURACY)})")
    out = _out_folder(args, scn)
    with OutputFolder(out) as tmp, SolverLog(tmp / LOG) as log:  # solver output to the log, bars on the terminal
        report = {"status": "ok", "scenario": scn.name, "meta": api.meta(scn), "studies": {}, "files": []}
        for name, study in studies.items():
            wp = study(scn, getattr(scn.analyses, name))
            report["studies"][name] = wp.to_dict()
            report["files"] += [f.name for f in wp.save(tmp)]
            if not args.quiet:
                with log.terminal():
                    print(wp.summary())
        write_json(tmp / "accuracy.json", report)
    if not args.quiet:
        print(f"results: {out / 'accuracy.json'}")
    return EXIT_OK


def _report(args) -> int:
    """Render report.html of an existing output folder."""
    try:
        path = report.render(args.folder)
    except ScenarioError as exc:
        print(f"autobal: bad input: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"report: {path}")
    return EXIT_OK


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="autobal", description=__doc__.splitlines()[0], epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--version", action="version", version=f"autobal {__version__}")
    sub = ap.add_subparsers(dest="cmd", required=True, metavar="COMMAND")

    def scene_args(p):
        p.add_argument("scenario", help="a YAML file, or the name of a shipped scenario (see 'autobal list')")
        p.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                       help="override a scene value, validated like the file "
                            "(repeatable), e.g. --set device.disc.face.base_gap='0.18 mm'")

    def out_args(p):
        p.add_argument("--out", type=Path, default=None, metavar="OUT",
                       help="output folder (default out/<scenario name>); replaced whole by each run")
        p.add_argument("--quiet", "-q", action="store_true",
                       help="print nothing but errors (no summaries, no progress bars)")

    p_run = sub.add_parser("run", help="run the analyses a scenario names", epilog=EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    scene_args(p_run)
    out_args(p_run)
    p_run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run sweeps and Monte Carlo on this dask.distributed scheduler (e.g. tcp://host:8786; "
                            "default: the environment variable AUTOBAL_SCHEDULER, else in-process); never from a "
                            "scene")
    p_acc = sub.add_parser("accuracy", help="error against run time of every solver of a scenario", epilog=EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    scene_args(p_acc)
    out_args(p_acc)
    p_check = sub.add_parser("check", help="validate a scenario without solving")
    scene_args(p_check)
    sub.add_parser("list", help="list the shipped scenarios")
    p_report = sub.add_parser("report", help="write OUT/report.html again from the results in an output folder")
    p_report.add_argument("folder", type=Path, metavar="OUT",
                          help="an output folder of 'autobal run' (holds results.json or failed_solve.json)")
    return ap


def _terminate(signum, frame):
    raise Interrupted(signum)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``autobal`` command; returns the exit code."""
    args = parser().parse_args(argv)
    if args.cmd == "list":
        try:
            for p in scenario.shipped():
                print(f"{p.stem:32s} {scenario.load(p).title}", flush=True)
        except BrokenPipeError:  # `autobal list | head`
            sys.stdout = None
        return EXIT_OK
    if args.cmd == "report":
        return _report(args)
    previous = signal.signal(signal.SIGTERM, _terminate)
    progress.set_quiet(getattr(args, "quiet", False))  # bars: on a terminal unless --quiet
    try:
        scn = scenario.load(args.scenario, overrides=_overrides(args.set))
        if args.cmd == "check":
            print(f"{scn.name}: valid; analyses: {', '.join(api.analyses(scn)) or 'none'}")
            for path, value, kind in quantities(scn, units.ANGULAR):  # the speeds as read: rad/s and rpm
                print(f"  {path} = {units.angular_text(value, kind)}")
            return EXIT_OK
        if args.cmd == "run":
            return _run(args, scn)
        return _accuracy(args, scn)
    except ScenarioError as exc:
        print(f"autobal: bad input: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SolveError as exc:
        print(f"autobal: solve failed: {exc}", file=sys.stderr)
        return EXIT_SOLVE_FAILED
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"autobal: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum
    finally:
        signal.signal(signal.SIGTERM, previous)
        progress.set_quiet(False)


if __name__ == "__main__":
    sys.exit(main())
