"""MkDocs hooks (``hooks:`` in ``mkdocs.yml``): math as MathML, seed/errata links.

* **Math.**  ``pymdownx.arithmatex`` (generic mode) wraps ``$…$`` / ``$$…$$`` — in pages and in
  the docstrings translated by ``scripts/docs_sphinx_roles.py`` — in
  ``<span|div class="arithmatex">``.  This hook converts each to MathML with ``latex2mathml``
  at build time, so the site needs neither JavaScript nor network; browsers render MathML
  natively.  A formula that does not convert fails the build (no raw LaTeX is published).
* **Sources.**  Every "seed 002", "seeds 002 and 004", "errata 003.3" in the text of a page
  (not in code, links or headings) links to its entry in ``bibliography.md``.
"""

from __future__ import annotations

import html
import posixpath
import re

_MATH_RE = re.compile(
    r'<(?P<tag>span|div) class="arithmatex">\s*(?:\\\((?P<inline>.*?)\\\)|\\\[(?P<block>.*?)\\\])'
    r"\s*</(?P=tag)>",
    re.S,
)
# "seed 002", "Seeds 000, 002 and 004", "errata 000.2", "errata 003.3/003.4" (one link each)
_SOURCE_RE = re.compile(
    r"\b(?P<word>[Ss]eeds?|[Ee]rrat(?:a|um))(?P<refs>\s+\d{3}(?:\.\d+)?"
    r"(?:(?:\s*,\s*|\s+and\s+|\s*/\s*|\s*[–-]\s*)\d{3}(?:\.\d+)?)*)"
)
_NUM_RE = re.compile(r"\d{3}(?:\.\d+)?")
_SKIP_TAGS = {"a", "code", "pre", "h1", "h2", "h3", "h4", "h5", "h6", "math", "script", "style"}
_TAG_RE = re.compile(r"<(/?)([a-zA-Z0-9]+)[^>]*?(/?)>")


def _mathml(latex: str, display: str, page) -> str:
    from latex2mathml.converter import convert
    from mkdocs.exceptions import PluginError

    tex = html.unescape(latex).strip()
    try:
        return convert(tex, display=display)
    except Exception as exc:  # noqa: BLE001 — any parser error is a broken page
        raise PluginError(f"{page.file.src_path}: cannot convert LaTeX {tex!r}: {exc}") from exc


def _anchor(number: str) -> str:
    return ("errata-" if "." in number else "seed-") + number.replace(".", "-")


def _link_sources(text: str, href: str) -> str:
    def refs(m: re.Match) -> str:
        is_errata = m.group("word").lower().startswith("errat")

        def one(n: re.Match) -> str:
            num = n.group(0)
            if is_errata != ("." in num):  # "errata 003" (a whole section) → the seed's errata
                anchor = f"errata-{num}" if is_errata else _anchor(num)
            else:
                anchor = _anchor(num)
            return f'<a href="{href}#{anchor}">{num}</a>'

        return m.group("word") + _NUM_RE.sub(one, m.group("refs"))

    return _SOURCE_RE.sub(refs, text)


def on_page_content(html_text: str, page, config, files) -> str:  # noqa: ARG001
    html_text = _MATH_RE.sub(
        lambda m: _mathml(m.group("inline") if m.group("inline") is not None else m.group("block"),
                          "inline" if m.group("inline") is not None else "block", page),
        html_text,
    )
    if page.file.src_uri == "bibliography.md":
        return html_text
    page_dir = page.url if page.url.endswith("/") else posixpath.dirname(page.url)
    href = posixpath.relpath("bibliography/" if config.get("use_directory_urls")
                             else "bibliography.html", page_dir or ".")
    if config.get("use_directory_urls"):
        href += "/"
    # link only in text outside the skipped elements
    out, depth, pos = [], 0, 0
    for m in _TAG_RE.finditer(html_text):
        chunk = html_text[pos:m.start()]
        out.append(chunk if depth else _link_sources(chunk, href))
        out.append(m.group(0))
        name = m.group(2).lower()
        if name in _SKIP_TAGS and not m.group(3):
            depth += -1 if m.group(1) else 1
            depth = max(depth, 0)
        pos = m.end()
    tail = html_text[pos:]
    out.append(tail if depth else _link_sources(tail, href))
    return "".join(out)
