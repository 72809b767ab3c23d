"""The README's Python example runs as written (in a fresh folder) and its CLI commands parse."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(), flags=re.S)


@pytest.mark.cli
def test_readme_python_example_runs(tmp_path, monkeypatch):
    blocks = _blocks("python")
    assert len(blocks) == 1, "the README has one Python example"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102 (the README's own code)
    import autobal

    runs = [v for v in namespace.values() if isinstance(v, autobal.Run)]
    assert runs and all(len(r) > 0 for r in runs)


def test_readme_is_short():
    assert README.stat().st_size <= 10 * 1024
