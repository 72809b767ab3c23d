"""Command line of autobal: run the analyses of a scenario, check it, list the shipped ones."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys
import time
from pathlib import Path

# only light modules here: main() installs its signal handlers before the solvers and models are imported,
# so a Ctrl-C while they load ends the command like any other interrupt
from autobal import __version__
from autobal.errors import Interrupted, ScenarioError, SolveError
from autobal.text import clean, clean_lines

EXIT_OK, EXIT_BAD_INPUT, EXIT_SOLVE_FAILED, EXIT_STDOUT_FAILED, EXIT_BROKEN_PIPE = 0, 2, 3, 74, 141

EPILOG = """\
exit codes:
  0    success
  2    bad input: one line naming the file or override, the field and the unit; or a file or
       folder that cannot be read or written (one line naming it and why, e.g. a full disk)
  3    failed solve: the solver status; its last iterate in OUT/failed_solve.json, or an
       analysis that finished with failures (a residual above its tolerance, an integrator
       failure): OUT/results.json with "status": "failed" and what failed under "failures"
  74   standard output cannot be written (e.g. > /dev/full): one line; the run's files are written
  130  interrupted (Ctrl-C, SIGINT); OUT holds interrupted.json
  141  standard output closed early (a broken pipe, e.g. | head): the command finishes quietly
  143  terminated (SIGTERM); OUT holds interrupted.json

Every run writes into a temporary folder beside OUT and moves it into place when it ends, so OUT
holds the files of exactly one run (of the last to end, when several write it at once); what
solvers print goes to OUT/autobal.log.
"""
# a dask.distributed address: scheme://host[:port] (host a name, an IPv4 or a bracketed IPv6 address)
SCHEDULER = re.compile(r"(tcp|tls|inproc|ucx|ws|wss)://([A-Za-z0-9_.-]+|\[[0-9A-Fa-f:.]+\])(:[0-9]{1,5})?/?")
_stdout = {"lost": None}  # why standard output can no longer be written (an OSError), else None


def _say(text: str) -> None:
    """Print ``text`` (cleaned) to standard output; once that fails, print nothing more (see :func:`main`)."""
    if _stdout["lost"] is not None:
        return
    try:
        print(clean_lines(text), flush=True)
    except OSError as exc:  # a broken pipe (| head), a full disk or /dev/full
        _stdout["lost"] = exc
        _quiet_stdout()


def _quiet_stdout() -> None:
    """Point standard output at /dev/null, so that what is still buffered can be flushed at exit."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no file descriptor (a test's captured stdout)
        pass


def _error(text: str) -> None:
    """One line on standard error: ``autobal: text``, cleaned and cut to a sane length."""
    try:
        print(f"autobal: {clean(text, 500)}", file=sys.stderr, flush=True)
    except OSError:
        pass


def _overrides(pairs: list[str]) -> dict:
    out = {}
    for pair in pairs:
        path, sep, value = pair.partition("=")
        if not sep or not path.strip():
            raise ScenarioError(f"--set {pair}: write PATH=VALUE, e.g. device.disc.outer_seal.length='300 mm'")
        out[path.strip()] = value.strip()
    return out


def _units(given: list[str]) -> dict[str, str]:
    """``--units KIND=UNIT[,KIND=UNIT...]`` (repeatable) -> kind -> display unit, spelled as the conversion
    table spells it; ScenarioError with one line naming the pair and the units of its kind."""
    from autobal.analysis.run.quantities import KINDS, unit_of_kind

    out = {}
    for pair in (p.strip() for item in given for p in item.split(",")):
        kind, sep, unit = (t.strip() for t in pair.partition("="))
        if not sep or not kind or not unit:
            raise ScenarioError(f"--units {pair}: write KIND=UNIT, e.g. --units pressure=bar,flow=m3/h "
                                f"(kinds: {', '.join(KINDS)})")
        try:
            out[kind] = unit_of_kind(kind, unit)
        except ValueError as exc:
            raise ScenarioError(f"--units {pair}: {exc}") from None
    return out


@contextlib.contextmanager
def _writing(out: Path):
    """An OSError without a file name, or naming a file of a temporary folder of ``out`` (a full disk while
    the run writes its files) says that the output folder cannot be written; the previous one is intact."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None or f"{os.sep}.{Path(out).name}." in str(exc.filename):
            raise ScenarioError(f"output folder {out}: cannot be written ({exc.strerror or exc}); "
                                f"what it held before is left as it was") from None
        raise


def _run(args, scn) -> int:
    from autobal import analyses, api

    out = args.out if args.out is not None else Path("out") / scn.name
    note = analyses.long_run_note(scn)
    if note and not args.quiet:
        _say(note)

    def show(name, result, seconds):
        if not args.quiet:
            _say(f"{result.summary()}\n  ({name}: {seconds:.2f} s)")

    with _writing(out):
        done = api.run(scn, out, on_result=show, scheduler=args.scheduler)
    if done.status != "ok":
        what = "; ".join(f"{name}: {f[0]}" + (f" (and {len(f) - 1} more)" if len(f) > 1 else "")
                         for name, f in done.failures.items())
        _error(f"solve failed: {what}; the results, marked failed, in {out / 'results.json'}")
        return EXIT_SOLVE_FAILED
    if not args.quiet:
        _say(f"results: {out / 'results.json'}")
    return EXIT_OK


def _accuracy(args, scn) -> int:
    """Work-precision of every analysis of the scene that has a provider: figure, CSV, summary; into
    ``out/NAME-accuracy`` unless ``--out`` (never the run's folder), interrupted.json on an interrupt."""
    from autobal import analyses, api
    from autobal.analysis.run.quantities import display_units

    studies = {name: analyses.module(name).accuracy for name in analyses.named(scn)
               if hasattr(analyses.module(name), "accuracy")}
    if not studies:
        raise ScenarioError(f"{scn.name}: none of its analyses has a work-precision study "
                            f"(available: {', '.join(analyses.accuracy_studies())})")
    out = args.out if args.out is not None else Path("out") / f"{scn.name}-accuracy"
    with _writing(out), display_units(api.display(scn)):
        return _write_accuracy(args, scn, studies, out)


def _write_accuracy(args, scn, studies: dict, out: Path) -> int:
    from autobal import api
    from autobal.analysis.run.result import write_json
    from autobal.output import LOG, OutputFolder, SolverLog, signals_held

    folder = OutputFolder(out)
    report = {"status": "ok", "scenario": scn.name, "meta": api.meta(scn), "studies": {}, "files": []}
    current = None
    try:
        with SolverLog(folder.tmp / LOG) as log:  # solver output to the log, bars on the terminal
            for current, study in studies.items():
                wp = study(scn, getattr(scn.analyses, current))
                report["studies"][current] = wp.to_dict()
                report["files"] += [f.name for f in wp.save(folder.tmp)]
                if not args.quiet:
                    with log.terminal():
                        _say(wp.summary())
        write_json(folder.tmp / "accuracy.json", report)
        folder.commit()
    except KeyboardInterrupt:
        with signals_held():  # a second interrupt is raised once interrupted.json is in place
            write_json(folder.tmp / "interrupted.json",
                       {"status": "interrupted", "analysis": current, "completed": list(report["studies"]),
                        "scenario": scn.name, "meta": report["meta"]})
            folder.commit()
        raise
    except BaseException:
        folder.discard()
        raise
    if not args.quiet:
        _say(f"results: {out / 'accuracy.json'}")
    return EXIT_OK


def _report(args) -> int:
    """Render report.html of an existing output folder; files that results.json names outside the
    folder are not embedded, and one warning line says so."""
    import warnings

    from autobal import report

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        path = report.render(args.folder, units=_units(args.units))
    for w in caught:
        _error(f"warning: {w.message}")
    _say(f"report: {path}")
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
                            "(repeatable), e.g. --set device.disc.outer_seal.length='300 mm'")

    def units_arg(p):
        p.add_argument("--units", action="append", default=[], metavar="KIND=UNIT[,...]",
                       help="show these kinds of quantity in these units (terminal, report tables, CSV headers, "
                            "statics figures; results.json stays SI), over the scene's display section, e.g. "
                            "--units pressure=bar,flow=m3/h,length=um,speed=rpm")

    def out_args(p):
        p.add_argument("--out", type=Path, default=None, metavar="OUT",
                       help="output folder (default out/<scenario name>); replaced whole by each run")
        p.add_argument("--quiet", "-q", action="store_true",
                       help="print nothing but errors (no summaries, no progress bars)")

    p_run = sub.add_parser("run", help="run the analyses a scenario names", epilog=EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    scene_args(p_run)
    out_args(p_run)
    units_arg(p_run)
    p_run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run sweeps and Monte Carlo on this dask.distributed scheduler (e.g. tcp://host:8786; "
                            "default: the environment variable AUTOBAL_SCHEDULER, else in-process); never from a "
                            "scene")
    p_acc = sub.add_parser("accuracy", help="error against run time of every solver of a scenario", epilog=EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    scene_args(p_acc)
    out_args(p_acc)
    units_arg(p_acc)
    p_check = sub.add_parser("check", help="validate a scenario without solving")
    scene_args(p_check)
    sub.add_parser("list", help="list the shipped scenarios")
    p_report = sub.add_parser("report", help="write OUT/report.html again from the results in an output folder")
    p_report.add_argument("folder", type=Path, metavar="OUT",
                          help="an output folder of 'autobal run' (holds results.json or failed_solve.json)")
    units_arg(p_report)
    p_explore = sub.add_parser("explore", help="a live what-if page of a scene on 127.0.0.1 (the explore extra)")
    p_explore.add_argument("scenario", help="a YAML file, or the name of a shipped scenario (see 'autobal list')")
    p_explore.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (default: a free one)")
    p_explore.add_argument("--no-browser", action="store_true", help="print the URL, do not open a browser")
    return ap


_state = {"since": None}
REPEAT_IGNORED_S = 5.0  # a second Ctrl-C this soon after the first lets the first finish writing OUT


def _terminate(signum, frame):
    """SIGINT and SIGTERM raise :class:`~autobal.errors.Interrupted`; a repeat within
    :data:`REPEAT_IGNORED_S` of the first is ignored (the run is already stopping and writing what it has)."""
    now = time.monotonic()
    if _state["since"] is None or now - _state["since"] > REPEAT_IGNORED_S:
        _state["since"] = now
        raise Interrupted(signum)


def _check_scheduler(address: str | None) -> None:
    if address is not None and not SCHEDULER.fullmatch(address):
        raise ScenarioError(f"--scheduler {address}: not a dask scheduler address; write SCHEME://HOST:PORT, "
                            f"e.g. tcp://localhost:8786")


def _os_error(exc: OSError) -> str:
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}cannot be read or written ({exc.strerror or exc})"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``autobal`` command; returns the exit code."""
    _state["since"], _stdout["lost"] = None, None
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGTERM, _terminate)
    if previous[signal.SIGINT] is signal.default_int_handler:  # not when started with SIGINT ignored
        signal.signal(signal.SIGINT, _terminate)
    code = EXIT_OK
    try:
        code = _main(parser().parse_args(argv))
    except ScenarioError as exc:
        _error(f"bad input: {exc}")
        code = EXIT_BAD_INPUT
    except SolveError as exc:
        _error(f"solve failed: {exc}")
        code = EXIT_SOLVE_FAILED
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        _error(f"interrupted ({signal.Signals(signum).name})")
        code = 128 + signum
    except OSError as exc:  # a full disk, a name too long, a folder without permission
        _error(_os_error(exc))
        code = EXIT_BAD_INPUT
    finally:
        # the command line (argv None) is about to exit: a late Ctrl-C must not raise in the interpreter's exit
        _end(previous if argv is not None else dict.fromkeys(previous, signal.SIG_IGN))
    if _stdout["lost"] is not None and code == EXIT_OK:
        if isinstance(_stdout["lost"], BrokenPipeError):
            return EXIT_BROKEN_PIPE
        _error(f"standard output cannot be written ({_stdout['lost'].strerror or _stdout['lost']})")
        return EXIT_STDOUT_FAILED
    return code


def _end(previous: dict) -> None:
    """Remove temporary folders no run will commit, flush standard output, give the signals back."""
    if "autobal.output" in sys.modules:  # else no output folder was begun (and nothing is imported now)
        sys.modules["autobal.output"].discard_uncommitted()
    try:
        sys.stdout.flush()
    except OSError as exc:
        _stdout["lost"] = _stdout["lost"] or exc
        _quiet_stdout()
    if "autobal.analysis.run.progress" in sys.modules:
        sys.modules["autobal.analysis.run.progress"].set_quiet(False)
    for sig, handler in previous.items():
        signal.signal(sig, handler)


def _extras_note(scn) -> str:
    """`` (needs the ross extra: pip install 'autobal[ross]', not installed)`` for a scene whose analyses need an
    optional extra, else ''."""
    from autobal import analyses

    return "".join(f" (needs the {name} extra{'' if ok else ': ' + analyses.EXTRAS[name][1] + ', not installed'})"
                   for name, ok in analyses.extras(scn).items())


def _main(args) -> int:
    from autobal import analyses, scenario, units
    from autobal.analysis.run import progress
    from autobal.schema import quantities

    if args.cmd == "list":
        for p in scenario.shipped():
            scn = scenario.load(p)
            _say(f"{p.stem:32s} {clean(scn.title)}{_extras_note(scn)}")
        return EXIT_OK
    if args.cmd == "report":
        return _report(args)
    if args.cmd == "explore":
        from autobal.explore import command

        return command(args)
    progress.set_quiet(getattr(args, "quiet", False))  # bars: on a terminal unless --quiet
    chosen = {f"display.{kind}": unit for kind, unit in _units(getattr(args, "units", [])).items()}
    scn = scenario.load(args.scenario, overrides=_overrides(args.set) | chosen)
    if args.cmd == "check":
        posed = analyses.check(scn)  # the spin-up problems posed as the run would, the drive's reach checked
        _say(f"{scn.name}: valid; analyses: {', '.join(analyses.named(scn)) or 'none'}{_extras_note(scn)}")
        if posed:
            _say(f"  posed without solving: {', '.join(posed)} (the drive reaches the final speed by the deadline)")
        for path, value, kind in quantities(scn, units.ANGULAR):  # the speeds as read: rad/s and rpm
            _say(f"  {path} = {units.angular_text(value, kind)}")
        return EXIT_OK
    if args.cmd in ("run", "accuracy"):
        missing = [name for name, installed in analyses.extras(scn).items() if not installed]
        if missing:
            how = analyses.EXTRAS[missing[0]][1]
            raise ScenarioError(f"{scn.name}: its analyses need the {missing[0]} extra, which is not installed: {how}")
    if args.cmd == "run":
        _check_scheduler(args.scheduler)
        return _run(args, scn)
    return _accuracy(args, scn)


if __name__ == "__main__":
    sys.exit(main())
