"""Every null in results.json has a status beside it.

A value that is NaN (written as null), or a list holding nulls, under key ``k`` needs a string
``k_status`` in the same mapping saying why; the accuracy blocks' ``estimate`` is explained by their
``how``.  Checked over the results of every shipped scene (run once per session).
"""

import pytest

from autobal import scenario
from autobal.analysis.run.result import plain


def unexplained_nulls(node, path="") -> list[str]:
    """Paths of the nulls (or lists holding nulls) that have no status beside them."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            where = f"{path}.{k}" if path else str(k)
            if (v is None or isinstance(v, list) and any(x is None for x in _flat(v))) and not _explained(node, k):
                out.append(where)
            out += unexplained_nulls(v, where)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += unexplained_nulls(v, f"{path}[{i}]")
    return out


def _flat(values):
    for x in values:
        if isinstance(x, list):
            yield from _flat(x)
        elif not isinstance(x, dict):
            yield x


def _explained(node: dict, key: str) -> bool:
    status = node.get(f"{key}_status", node.get("how") if key == "estimate" else None)
    return isinstance(status, str) and bool(status.strip())


def test_the_checker_finds_unexplained_nulls():
    data = {"a": None, "a_status": "why", "b": [1.0, None], "c": {"d": None},
            "e": [{"f": [[None]]}, {"g": None, "g_status": ""}], "accuracy": {"estimate": None, "how": "none"}}
    assert unexplained_nulls(data) == ["b", "c.d", "e[0].f", "e[1].g"]


SHIPPED = [p.stem for p in scenario.shipped()]


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_every_null_has_a_status(shipped_run, name):
    assert unexplained_nulls(plain(shipped_run(name)[0].to_dict())) == []
