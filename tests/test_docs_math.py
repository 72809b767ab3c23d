"""Mathematics of the documentation site: TeX in the theory pages becomes MathML when the site is built
(docs/hooks.py, latex2mathml), with the sources' equation numbers, and a built page fetches nothing from
elsewhere (no external script or stylesheet)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.extra("docs")
pytest.importorskip("mkdocs")
pytest.importorskip("latex2mathml")
markdown = pytest.importorskip("markdown")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
THEORY = sorted((DOCS / "theory").glob("*.md")) + [DOCS / "design.md", DOCS / "ross_rotor.md"]


def _hooks():
    spec = importlib.util.spec_from_file_location("autobal_docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hooks = _hooks()


class _Page:
    def __init__(self, src_uri):
        self.file = type("File", (), {"src_uri": src_uri})()


def _render(text: str, src_uri: str = "page.md") -> str:
    """A page through Markdown with arithmatex as mkdocs.yml configures it, then the hook."""
    body = markdown.markdown(text, extensions=["tables", "pymdownx.superfences", "pymdownx.arithmatex"],
                             extension_configs={"pymdownx.arithmatex": {"generic": True}})
    return hooks.on_page_content(body, _Page(src_uri), None, None)


def test_display_equation_gets_mathml_and_the_source_number():
    out = hooks.math_html(r"\psi_3=\psi_2-\frac{b\psi_1-\chi}{\sigma}\tag{2.20}", display=True)
    assert out.startswith('<div class="equation"><math') and 'display="block"' in out
    assert "<mfrac>" in out and "&#x003C8;" in out  # a fraction, and psi as a MathML character
    assert out.endswith('<span class="eqno">(2.20)</span></div>')
    assert "tag" not in out


def test_inline_formula_and_untagged_display():
    assert hooks.math_html(r"u^{3/2}", display=False).startswith('<math xmlns="http://www.w3.org/1998/Math/MathML"')
    assert "eqno" not in hooks.math_html(r"\dot X = AX + Bw", display=True)


UNCONVERTIBLE = [r"\begin{aligned}a&=b\\c&=d\end{aligned}", r"a\tag{1}\tag{2}", r"\begin{array}{l}a\\[6pt]b\end{array}"]


@pytest.mark.parametrize("tex", UNCONVERTIBLE)
def test_formula_latex2mathml_cannot_render_is_refused(tex):
    with pytest.raises(ValueError):
        hooks.math_html(tex, display=True)


def test_page_markdown_to_mathml_escapes_and_code():
    html = _render("A gap $u<1$ and\n\n$$\nq=\\sqrt{1-\\tau/\\tau_\\text{max}}\\tag{4.31}\n$$\n\n"
                   "`$HOME` stays code.\n", "x.md")
    assert html.count("<math") == 2 and "(4.31)" in html
    assert "<mo>&#x0003C;</mo>" in html  # the escaped "<" reached latex2mathml as "<"
    assert "<code>$HOME</code>" in html and "arithmatex" not in html


def test_a_bad_formula_names_its_page():
    with pytest.raises(ValueError, match="theory/x.md"):
        _render("$$\n\\begin{aligned}a&=b\\end{aligned}\n$$\n", "theory/x.md")


@pytest.mark.parametrize("page", THEORY, ids=lambda p: p.name)
def test_every_theory_page_renders_its_equations(page):
    html = _render(page.read_text(encoding="utf-8"), page.name)
    assert "<math" in html, f"{page.name}: no rendered mathematics"
    assert "arithmatex" not in html and "\\(" not in html and "\\[" not in html
    assert "$$" not in html, f"{page.name}: a display formula was not recognised"


def test_equation_numbers_are_the_sources():
    """The numbered equations of the statics page are Pavlenko (2014)'s chapter 2 numbers, in order."""
    html = _render((ROOT / "docs" / "theory" / "statics.md").read_text(encoding="utf-8"))
    numbers = re.findall(r'<span class="eqno">\(([^)]*)\)</span>', html)
    assert numbers == ["2.15", "2.16", "2.18", "2.19", "2.27", "2.31", "2.32", "2.35", "2.36"]


@pytest.mark.slow
def test_built_site_has_mathml_and_fetches_nothing(tmp_path):
    """The strict build of the whole site: a theory page carries MathML with the source's numbers, and no page
    loads a script or a stylesheet from another host."""
    site = tmp_path / "site"
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(site)],
                         cwd=ROOT, capture_output=True, text=True, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert run.returncode == 0, run.stderr[-2000:]
    page = (site / "theory" / "statics" / "index.html").read_text(encoding="utf-8")
    assert page.count("<math") >= 9 and '<span class="eqno">(2.19)</span>' in page
    external = re.compile(r"""<(?:script[^>]*\ssrc|link[^>]*\shref)=["']?(?:https?:)?//""", re.I)
    for html in site.rglob("*.html"):
        text = html.read_text(encoding="utf-8")
        assert not external.search(text), f"{html.relative_to(site)} loads {external.search(text).group(0)}"

