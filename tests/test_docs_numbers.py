"""Published numbers come from generators (issue 12, deliverable 1).

* every ``--8<--`` include of a page exists and is written by a generator that
  ``scripts/make_docs_data.py`` runs;
* every generated block spliced into a page (``<!-- name:begin … -->`` … ``<!-- name:end -->``)
  belongs to a listed generator;
* every script of ``scripts/`` and ``benchmarks/`` with a command-line entry point is either
  listed in ``make_docs_data.GENERATORS`` or named below with the reason it is not a generator;
* the pages cleaned of hand-typed measurements (:data:`CHECKED_PAGES`) contain no measured-looking
  number (a mantissa with decimals and an exponent, e.g. ``3.4e-5``, or a time in ms/µs) outside
  code, generated fragments and the per-page whitelist.

No build is needed (fast); the site build itself fails on a missing include
(``pymdownx.snippets`` with ``check_paths``), see ``tests/test_docs_site.py``.
"""

from __future__ import annotations

import fnmatch
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(ROOT / "scripts"))

import make_docs_data  # noqa: E402

INCLUDE = re.compile(r'^\s*--8<--\s+"([^"]+)"\s*$', re.M)
BLOCK = re.compile(r"<!-- (\w+):begin\b[^>]*-->.*?<!-- \1:end -->", re.S)
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
CODE = re.compile(r"`[^`\n]+`")
#: a measured-looking number: 3.4e-5, 1.2e-06, 0.28 s … no: seconds are too common in prose;
#: times in ms / µs and decimal-mantissa scientific notation are what retyped tables contain
MEASURED = re.compile(r"(?<![\w.])\d+\.\d+e[-+]?\d+\b|(?<![\w.])\d+(?:\.\d+)? ?(?:ms|µs)\b")

#: scripts with a ``__main__`` that are not generators of published files, and why
NOT_GENERATORS = {
    "scripts/docs_hooks.py": "MkDocs hook, runs inside the site build",
    "scripts/docs_sphinx_roles.py": "Griffe extension, runs inside the site build",
    "scripts/numpy_simd_variant.py": "CI helper: picks a NumPy SIMD variant to disable",
    "scripts/make_docs_data.py": "the entry point itself",
    "benchmarks/bench_analytic.py": "pytest-benchmark suite (its table is printed, not published)",
    "benchmarks/bench_sun.py": "pytest-benchmark suite (its table is printed, not published)",
}

#: pages whose hand-typed measurements were replaced by generated fragments, and the
#: measured-looking numbers still allowed in their prose (with the reason)
CHECKED_PAGES: dict[str, dict[str, str]] = {
    "convergence.md": {},
}


def _pages():
    return sorted(DOCS.rglob("*.md"))


def _outputs() -> list[str]:
    return [o for g in make_docs_data.GENERATORS for o in g.outputs]


def _generated(rel: str) -> bool:
    return any(fnmatch.fnmatch(rel, pat) for pat in _outputs())


def test_every_include_exists_and_is_generated():
    missing, orphan = [], []
    for page in _pages():
        for inc in INCLUDE.findall(page.read_text(encoding="utf-8")):
            rel = f"docs/{inc}"
            if not (DOCS / inc).is_file():
                missing.append(f"{page.relative_to(ROOT)} includes {inc}")
            elif not _generated(rel):
                orphan.append(f"{page.relative_to(ROOT)} includes {inc}")
    assert not missing, "includes of missing files:\n" + "\n".join(missing)
    assert not orphan, ("included fragments that no generator of make_docs_data.py writes:\n"
                        + "\n".join(orphan))


def test_spliced_blocks_belong_to_generators():
    names = {g.name for g in make_docs_data.GENERATORS}
    scripts = {Path(g.script).stem for g in make_docs_data.GENERATORS}
    bad = []
    for page in _pages():
        text = page.read_text(encoding="utf-8")
        for m in BLOCK.finditer(text):
            marker = m.group(1)
            if marker not in names and marker not in scripts:
                bad.append(f"{page.relative_to(ROOT)}: block {marker!r}")
            owner = next((g for g in make_docs_data.GENERATORS
                          if marker in (g.name, Path(g.script).stem)), None)
            if owner and str(page.relative_to(ROOT)) not in owner.outputs:
                bad.append(f"{page.relative_to(ROOT)}: {owner.name} does not list the page")
    assert not bad, "\n".join(bad)


def test_entry_point_lists_every_generator():
    listed = {g.script for g in make_docs_data.GENERATORS}
    for g in make_docs_data.GENERATORS:
        assert (ROOT / g.script).is_file(), g.script
        assert g.full_needs in (None, "--with-ms-study"), g.name
    unlisted = []
    for folder in ("scripts", "benchmarks"):
        for path in sorted((ROOT / folder).glob("*.py")):
            rel = f"{folder}/{path.name}"
            if "__main__" not in path.read_text(encoding="utf-8"):
                continue
            if rel not in listed and rel not in NOT_GENERATORS:
                unlisted.append(rel)
    assert not unlisted, ("scripts with a command line that are neither generators in "
                          "scripts/make_docs_data.py nor in NOT_GENERATORS: " + ", ".join(unlisted))
    assert not set(NOT_GENERATORS) & listed


def test_generator_outputs_exist():
    absent = []
    for pat in _outputs():
        if not any(fnmatch.fnmatch(str(p.relative_to(ROOT)), pat) for p in
                   (ROOT / Path(pat).parent).glob(Path(pat).name)):
            absent.append(pat)
    assert not absent, f"generator outputs not in the repository: {absent}"


def test_quick_mode_writes_only_into_out(tmp_path):
    """The quick commands of every generator name the temp dir (nothing written in docs/)."""
    for g in make_docs_data.GENERATORS:
        args = " ".join(g.quick)
        writes = any(a.startswith("--out") or a == "--write" for a in g.quick)
        assert "--write" not in g.quick, g.name
        if writes:
            assert "{out}" in args, g.name


def _prose(text: str) -> str:
    text = BLOCK.sub("", text)
    text = FENCE.sub("", text)
    text = INCLUDE.sub("", text)
    return CODE.sub("", text)


@pytest.mark.parametrize("page", sorted(CHECKED_PAGES))
def test_no_hand_typed_measurements(page):
    allowed = CHECKED_PAGES[page]
    found = [m.group(0) for m in MEASURED.finditer(_prose((DOCS / page).read_text(encoding="utf-8")))]
    bad = [f for f in found if f not in allowed]
    assert not bad, (f"docs/{page}: measured-looking numbers outside generated fragments "
                     f"(generate them, or whitelist with a reason): {bad}")


def test_measured_pattern():
    assert MEASURED.findall("worst 3.4e-5, took 140 µs and 0.28 ms") == ["3.4e-5", "140 µs", "0.28 ms"]
    assert not MEASURED.findall("tolerance 1e-3, seed 002, Eq. 5.1, 1976, x1.5e3y")
