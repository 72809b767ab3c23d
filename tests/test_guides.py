"""The guides (docs/guides/*.md) run as written: every ```bash title="run"``` and ```python title="run"```
block is executed in a fresh folder holding the guide's example files (scenarios/examples/), in order, and
every ```text title="prints (excerpt)"``` block that follows one must appear in what it printed, its numbers to 4
significant digits (so a guide cannot quote a number its run does not give).  A run block titled
``run (exits with N)`` must end with exit code N.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDES = ROOT / "docs" / "guides"
EXAMPLES = ROOT / "scenarios" / "examples"
BLOCK = re.compile(r'^```(\w+)[ \t]*(?:title="([^"]*)")?[^\n]*\n(.*?)^```[ \t]*$', re.S | re.M)
INCLUDE_CODE = re.compile(r"<!--\s*include-code:\s*(\S+)\s*-->")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
EXIT = re.compile(r"run \(exits with (\d+)\)")
RTOL = 5e-4  # a quoted number to its 4 significant digits


def blocks(page: Path) -> list[tuple[str, str, str]]:
    """(language, title, text) of the fenced blocks of a guide, in order."""
    return [(m[1], m[2] or "", m[3]) for m in BLOCK.finditer(page.read_text(encoding="utf-8"))]


def _pattern(line: str) -> tuple[re.Pattern, list[float]]:
    """A regular expression matching ``line`` with any numbers where it has numbers, and those numbers."""
    parts, numbers, last = [], [], 0
    for m in NUMBER.finditer(line):
        parts.append(r"\s+".join(re.escape(w) for w in line[last:m.start()].split(" ")))
        parts.append(f"({NUMBER.pattern})")
        numbers.append(float(m[0]))
        last = m.end()
    parts.append(r"\s+".join(re.escape(w) for w in line[last:].split(" ")))
    return re.compile("".join(parts)), numbers


def _close(quoted: float, printed: float) -> bool:
    return abs(quoted - printed) <= RTOL * max(abs(quoted), abs(printed)) + 1e-12


def assert_printed(expected: str, output: str, where: str) -> None:
    """Every line of ``expected`` (but '...') appears in ``output``, its numbers within :data:`RTOL`."""
    for line in expected.strip().splitlines():
        line = line.strip()
        if not line or line == "...":
            continue
        pattern, quoted = _pattern(" ".join(line.split()))
        found = [[float(g) for g in m.groups()] for m in pattern.finditer(output)]
        assert found, f"{where}: the guide quotes {line!r}; the run printed:\n{output}"
        assert any(all(_close(q, p) for q, p in zip(quoted, got, strict=True)) for got in found), (
            f"{where}: the guide quotes {line!r}; the run printed {pattern.pattern} with {found}")


def run_bash(text: str, cwd: Path) -> tuple[int, str]:
    env = {k: v for k, v in os.environ.items() if k != "AUTOBAL_SCHEDULER"}  # in process, as the guide runs it
    env |= {"PATH": f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}", "COLUMNS": "120"}
    p = subprocess.run(["bash", "-c", text], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    return p.returncode, p.stdout + p.stderr


def run_python(text: str, cwd: Path, namespace: dict) -> tuple[int, str]:
    out = io.StringIO()
    old = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(text, "guide", "exec"), namespace)  # noqa: S102 - the guide's own code
    finally:
        os.chdir(old)
    return 0, out.getvalue()


def run_guide(page: Path, folder: Path) -> int:
    """Execute the guide's run blocks in ``folder`` and check its prints blocks; the number of blocks run."""
    for f in EXAMPLES.iterdir():
        if f.is_file():
            shutil.copy(f, folder / f.name)
    namespace: dict = {}
    output, ran = None, 0
    for i, (lang, title, text) in enumerate(blocks(page)):
        where = f"{page.name}, block {i + 1} ({lang} {title!r})"
        if title.startswith("run"):
            code, output = (run_bash(text, folder) if lang == "bash" else run_python(text, folder, namespace))
            want = int(EXIT.fullmatch(title)[1]) if EXIT.fullmatch(title) else 0
            assert code == want, f"{where}: exit code {code}, the guide says {want}:\n{output}"
            ran += 1
        elif title.startswith("prints"):
            assert output is not None, f"{where}: a prints block before any run block"
            assert_printed(text, output, where)
    return ran


PAGES = sorted(GUIDES.glob("*.md"))


def test_every_guide_is_in_the_navigation_and_every_example_in_a_guide():
    nav = (ROOT / "mkdocs.yml").read_text()
    assert [p.stem for p in PAGES] == sorted(["spinup", "device", "fit", "runup"])
    for p in PAGES:
        assert f"guides/{p.name}" in nav, p.name
    included = {m for p in PAGES for m in INCLUDE_CODE.findall(p.read_text(encoding="utf-8"))}
    shipped = {f"scenarios/examples/{f.name}" for f in EXAMPLES.iterdir() if f.suffix in (".yaml", ".csv")}
    assert included == shipped
    for p in PAGES:
        titles = [t for _, t, _ in blocks(p)]
        assert any(t.startswith("run") for t in titles) and any(t.startswith("prints") for t in titles), p.name
        for lang, title, text in blocks(p):  # every command and Python block is run
            assert lang not in ("bash", "python", "sh", "console") or title.startswith("run"), (p.name, text)


def test_prints_blocks_compare_numbers_to_four_digits():
    """The checker itself: a quoted line is found with its numbers to 4 digits, and not otherwise."""
    out = "  peak deflection  12.34 µm at 1799 rpm (188.4 rad/s)\nstatus: ok\n"
    assert_printed("peak deflection 12.34 µm at 1799 rpm (188.4 rad/s)", out, "t")
    assert_printed("...\nstatus: ok", out, "t")
    for wrong in ("peak deflection 12.40 µm at 1799 rpm", "peak deflection 12.34 mm", "status: failed"):
        with pytest.raises(AssertionError):
            assert_printed(wrong, out, "t")


@pytest.mark.slow
@pytest.mark.cli
@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_guide_runs_as_written(page, tmp_path):
    assert run_guide(page, tmp_path) >= 2
