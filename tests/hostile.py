"""Shared by the hostile-input tests: run a shipped scene with overrides through the CLI and return its one line."""

from autobal import cli


def refused(capsys, scene: str, *sets: str) -> str:
    """``autobal run scene --set ...`` exits 2 with exactly one line on stderr, which is returned (nothing written:
    the output folder does not exist)."""
    args = ["run", scene, "--out", "/nonexistent/never-written", "-q"]
    for s in sets:
        args += ["--set", s]
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err
