"""The suite's organisation: unit / literature (golden values from the sources) / CLI (end to end).

Read from the test modules' source with ``ast`` (nothing is imported or solved): every category is
non-empty, every test that runs the CLI or the Python API end to end (``cli.main``, ``autobal.run``,
directly or through a helper or fixture of its module) is marked ``cli``, and the markers are registered.
"""

import ast
from pathlib import Path

TESTS = Path(__file__).parent
CATEGORIES = ("literature", "cli", "slow")


def _modules() -> dict[str, ast.Module]:
    return {p.name: ast.parse(p.read_text(), p.name) for p in sorted(TESTS.glob("test_*.py"))}


def _mark_names(decorators) -> set[str]:
    """Names X of ``pytest.mark.X`` / ``pytest.mark.X(...)`` among decorators or a pytestmark value."""
    out = set()
    for d in decorators:
        node = d.func if isinstance(d, ast.Call) else d
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) and node.value.attr == "mark":
            out.add(node.attr)
    return out


def _module_marks(tree: ast.Module) -> set[str]:
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "pytestmark" for t in node.targets):
            value = node.value
            return _mark_names(value.elts if isinstance(value, ast.List | ast.Tuple) else [value])
    return set()


def _functions(tree: ast.Module) -> dict[str, ast.FunctionDef]:
    """Module-level functions and the methods of module-level classes (tests, helpers, fixtures)."""
    out = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out[node.name] = node
        elif isinstance(node, ast.ClassDef):
            out.update({f.name: f for f in node.body if isinstance(f, ast.FunctionDef)})
    return out


def _main_names(tree: ast.Module) -> set[str]:
    """Local names bound to autobal.cli.main (``from autobal.cli import main [as x]``, anywhere)."""
    return {a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module == "autobal.cli"
            for a in n.names if a.name == "main"}


def _runs_end_to_end(fn: ast.FunctionDef, main_names: set[str]) -> bool:
    """Whether ``fn`` itself calls cli.main, a name bound to it, autobal.run or api.run."""
    for n in ast.walk(fn):
        if not isinstance(n, ast.Call):
            continue
        f = n.func
        if isinstance(f, ast.Name) and f.id in main_names:
            return True
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and (
                (f.value.id == "cli" and f.attr == "main") or (f.value.id in ("autobal", "api") and f.attr == "run")):
            return True
    return False


def end_to_end_tests(tree: ast.Module) -> set[str]:
    """Tests of a module that run the CLI or the API end to end, directly or through a helper function
    or a fixture (a test argument) of the same module, transitively."""
    funcs, mains = _functions(tree), _main_names(tree)
    calls = {name: {n.id for n in ast.walk(fn) if isinstance(n, ast.Name) and n.id in funcs}
             | {a.arg for a in fn.args.args if a.arg in funcs} for name, fn in funcs.items()}
    e2e = {name for name, fn in funcs.items() if _runs_end_to_end(fn, mains)}
    grown = True
    while grown:
        new = {name for name, used in calls.items() if used & e2e} - e2e
        e2e |= new
        grown = bool(new)
    return {name for name in e2e if name.startswith("test")}


def marks_of(tree: ast.Module) -> dict[str, set[str]]:
    """Test name -> its marks (its decorators and the module's pytestmark)."""
    module = _module_marks(tree)
    return {name: _mark_names(fn.decorator_list) | module for name, fn in _functions(tree).items()
            if name.startswith("test")}


def test_markers_are_registered_and_strict(pytestconfig):
    registered = {m.split(":")[0].strip() for m in pytestconfig.getini("markers")}
    assert set(CATEGORIES) <= registered
    assert "--strict-markers" in pytestconfig.getini("addopts")


def test_every_category_is_non_empty():
    counts = dict.fromkeys((*CATEGORIES, "unit"), 0)
    for tree in _modules().values():
        for marks in marks_of(tree).values():
            for m in CATEGORIES:
                counts[m] += m in marks
            counts["unit"] += not marks & {"literature", "cli"}
    assert all(counts.values()), counts


def test_every_end_to_end_test_is_marked_cli():
    unmarked = [f"{name}::{test}" for name, tree in _modules().items() for test in sorted(end_to_end_tests(tree))
                if "cli" not in marks_of(tree)[test]]
    assert not unmarked, f"run the CLI or autobal.run but are not marked cli: {unmarked}"


def test_the_checker_finds_an_unmarked_end_to_end_test():
    tree = ast.parse(
        "from autobal.cli import main as run_cli\nimport pytest\n"
        "def helper(x):\n    return run_cli(['run', x])\n"
        "@pytest.fixture\ndef ran(tmp_path):\n    return helper(str(tmp_path))\n"
        "def test_a(ran):\n    assert ran == 0\n"
        "@pytest.mark.cli\ndef test_b():\n    assert helper('x') == 0\n"
        "def test_c():\n    assert 1 + 1 == 2\n")
    assert end_to_end_tests(tree) == {"test_a", "test_b"}
    assert marks_of(tree) == {"test_a": set(), "test_b": {"cli"}, "test_c": set()}
