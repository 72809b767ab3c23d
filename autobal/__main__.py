"""``python -m autobal`` and the ``autobal`` command: the command line, with a Ctrl-C while the command line
itself is imported ending like any other interrupt (exit 130, one line)."""

import sys


def entry() -> int:
    """Import the command line and run it; :func:`autobal.cli.main` handles signals from then on."""
    try:
        from autobal.cli import main
    except KeyboardInterrupt:
        sys.stderr.write("autobal: interrupted (SIGINT)\n")
        return 130
    return main()


if __name__ == "__main__":
    raise SystemExit(entry())
