"""The documentation site builds (``mkdocs build --strict``) and shows no raw reST or LaTeX.

The API reference is generated from numpy-style docstrings written with Sphinx roles and
``.. math::``; ``scripts/docs_sphinx_roles.py`` (a Griffe extension) and
``scripts/docs_hooks.py`` (MathML, bibliography links) make them render.  The build takes
a few seconds, so it runs in the default test selection.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

import docs_hooks  # noqa: E402
import docs_sphinx_roles  # noqa: E402

RAW_ROLE = re.compile(r":(?:py:)?(?:func|class|data|meth|attr|mod|obj|exc|const|math):(?:`|<code>)")
RAW_MATH = re.compile(r"\.\. math::|\$\$|class=\"arithmatex\"")
# a LaTeX command in the text of a page (MathML output contains none: it spells symbols out)
RAW_LATEX = re.compile(r"\\(?:frac|mathrm|int|sum|sqrt|left|right|cdot|theta|lambda|beta|pi|qquad|text)\b")
_ELEMENT = re.compile(r"<(code|pre|script|style)\b.*?</\1>", re.S)


def _has(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


needs_docs = pytest.mark.skipif(
    not all(_has(m) for m in ("mkdocs", "mkdocstrings_handlers", "pymdownx", "latex2mathml")),
    reason="docs extra not installed (pip install '.[docs]')",
)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-4000:]}"
    return out


def _pages(site: Path) -> dict[str, str]:
    pages = {str(p.relative_to(site)): p.read_text(encoding="utf-8") for p in site.rglob("*.html")}
    assert len(pages) > 40  # the whole site, not an empty build
    return pages


@needs_docs
def test_no_raw_roles_or_latex(site):
    bad = []
    for name, text in _pages(site).items():
        for pattern in (RAW_ROLE, RAW_MATH):
            bad += [f"{name}: {m.group(0)!r}" for m in pattern.finditer(text)]
        prose = _ELEMENT.sub("", text)  # code samples may legitimately show markup
        bad += [f"{name}: {m.group(0)!r}" for m in RAW_LATEX.finditer(prose)]
    assert not bad, "raw markup in the built site:\n" + "\n".join(bad[:40])


@needs_docs
def test_math_and_cross_references_render(site):
    pages = _pages(site)
    phase = pages[os.path.join("api", "phase", "index.html")]
    assert phase.count("<math") >= 3  # the Rayleigh, Henyey–Greenstein and Cornette–Shanks formulas
    single = pages[os.path.join("api", "sky_single", "index.html")]
    # a Sphinx role became a link to the object's anchor (same page and across pages)
    assert 'href="#atmoscatter.sky.single.single_scattering"' in single
    assert "../sky_multiple/#atmoscatter.sky.multiple.multiple_scattering" in single
    # an object defined in a private module links to where its module's __all__ re-exports
    # it (TABLE_FLOOR lives in sky/_single_table.py): its permalink and a role's link
    assert single.count('href="#atmoscatter.sky.single.TABLE_FLOOR"') >= 2
    # seed mentions link to the bibliography, whose anchors exist
    sun = pages[os.path.join("theory", "sun", "index.html")]
    assert 'href="../../bibliography/#seed-003"' in sun
    bib = pages[os.path.join("bibliography", "index.html")]
    linked = set(re.findall(r'bibliography/#([\w-]+)"', "".join(pages.values())))
    missing = sorted(a for a in linked if f'id="{a}"' not in bib)
    assert linked and not missing, f"links to missing bibliography anchors: {missing}"


# --- the converter and the hook on small inputs (no build needed) ----------------------------

def test_convert_math_block_and_inline():
    text = "Formula\n\n.. math::\n\n    a = \\frac{1}{2}\n    + b\n\nwith :math:`x^2` here."
    out = docs_sphinx_roles.convert(text)
    assert "$$\na = \\frac{1}{2}\n+ b\n$$" in out
    assert "with $x^2$ here." in out
    one_line = docs_sphinx_roles.convert("Text\n\n    .. math:: p = 1 +\n              q\n\nAfter.")
    assert "    $$\n    p = 1 +\n    q\n    $$" in one_line and "After." in one_line


def test_convert_roles_without_resolver_are_code():
    out = docs_sphinx_roles.convert(":func:`~atmoscatter.render` and :class:`Scene <a.b.Scene>`")
    assert out == "`render()` and `Scene`"
    assert docs_sphinx_roles.convert("Example::\n\n    x = 1") == "Example:\n\n    x = 1"


def test_source_links():
    out = docs_hooks._link_sources("seeds 002 and 004, errata 003.3; Seed 000", "b/")
    assert out == ('seeds <a href="b/#seed-002">002</a> and <a href="b/#seed-004">004</a>, '
                   'errata <a href="b/#errata-003-3">003.3</a>; Seed <a href="b/#seed-000">000</a>')


def test_public_objects_section_becomes_a_list():
    text = "Summary.\n\nPublic objects\n--------------\nfoo, BAR\n    What they are.\n\nNotes\n-----\nx\n    y"
    out = docs_sphinx_roles.convert(text)
    assert "- `foo`, `BAR` —\n    What they are." in out
    assert out.endswith("Notes\n-----\nx\n    y")  # other sections are left alone


def test_explicit_member_lists_name_every_public_class_and_function():
    """A page that lists a module's members (to keep the source order of names re-exported
    from private modules) renders every class and function of the module's ``__all__``."""
    import importlib
    import inspect

    block = re.compile(r"^::: (\S+)\n    options:\n      members:\n((?:        - \S+\n)+)", re.M)
    found = 0
    for page in sorted((ROOT / "docs" / "api").glob("*.md")):
        for m in block.finditer(page.read_text(encoding="utf-8")):
            found += 1
            mod = importlib.import_module(m.group(1))
            listed = re.findall(r"- (\S+)", m.group(2))
            public = {n for n in mod.__all__
                      if inspect.isclass(getattr(mod, n)) or inspect.isroutine(getattr(mod, n))}
            assert set(listed) <= set(mod.__all__), f"{page.name}: not exported: {set(listed) - set(mod.__all__)}"
            assert public <= set(listed), f"{page.name}: not rendered: {sorted(public - set(listed))}"
    assert found >= 2  # sky_single.md and sky_aerial.md
