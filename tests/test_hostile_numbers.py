"""Hostile input to the documentation's numbers: a placeholder that names no recorded value, a malformed one,
an unknown scene for docs/run_numbers.py: each refused with one line naming it."""

import re

import pytest

pytestmark = pytest.mark.extra("docs")
pytest.importorskip("mkdocs")  # before the import below: test_docs_numbers skips itself without mkdocs

from tests.test_docs_numbers import hooks, runner  # noqa: E402


@pytest.mark.parametrize("placeholder, message", [
    ("{{ n:pump_pe600_design.no_such_value }}", "no value 'no_such_value' in pump_pe600_design"),
    ("{{ n:no_such_run.x }}", "no_such_run: no run of that name"),
    ("{{ n:pump_pe600_design.decay_rate_1_s.9 }}", "no value '9'"),
    ("{{ n:pump_pe600_design:.2f }}", "is not a number"),
    ("{{ n:pump_pe600_design.objective:.2q }}", "Unknown format code"),
    ("{{ n:pump_pe600_design.objective:.2f", "not of the form"),
    ("{{ run:no_such_run }}", "no_such_run: no run of that name"),
])
def test_an_unknown_placeholder_stops_the_build(placeholder, message):
    with pytest.raises(hooks.UnknownNumber, match=re.escape(message)):
        hooks.numbers_markdown(f"text {placeholder} text")

    class Page:
        class file:
            src_path = "x.md"

    with pytest.raises(ValueError, match=r"x\.md: .*" + re.escape(message)):
        hooks.on_page_markdown(f"text {placeholder} text", Page, None, None)


def test_an_unknown_scene_is_refused_with_exit_2(capsys):
    assert runner.main(["no_such_scene"]) == 2
    assert runner.main(["--check", "no_such_scene"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith("unknown scene no_such_scene: one of ") for line in err)
