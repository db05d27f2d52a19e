"""Render the package's reStructuredText docstring markup in the MkDocs API reference.

The docstrings are numpy style with Sphinx roles (``:func:`x```, ``:class:`~a.B```, ``:data:``,
``:meth:``, ``:attr:``, ``:mod:``), ``.. math::`` blocks, ``:math:`` roles and ``::`` literal
blocks, which mkdocstrings would print as raw text.  Rather than rewriting ~500 roles in the
sources (they read well in ``help()``), this Griffe extension translates them when
mkdocstrings loads the package:

* a role whose target is an object the API reference renders becomes an autorefs
  cross-reference ``[`name`][canonical.path]`` (an object defined in a private module and
  re-exported through the ``__all__`` of a documented module links to that re-export, which
  is where mkdocstrings renders it); any other target (private helpers, the standard
  library, SciPy, undocumented constants) becomes plain code ``name``;
* ``.. math::`` becomes a ``$$ … $$`` block and ``:math:`x``` becomes ``$x$``, which
  ``pymdownx.arithmatex`` marks up and ``scripts/docs_hooks.py`` turns into MathML at build time
  (no JavaScript, no network);
* a paragraph ending in ``::`` (reST "literal block follows") ends in ``:``;
* the name/description pairs of the modules' "Public objects" sections become bullet lists
  whose names link to the objects.

Loaded from ``mkdocs.yml`` (``plugins: mkdocstrings: handlers: python: options: extensions``).

Run as a script, it lists the raw roles and ``.. math::`` directives left in the given files
(``python scripts/docs_sphinx_roles.py atmoscatter/*.py``) — informational, since the
extension handles them all at build time.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROLE_RE = re.compile(r":(?:py:)?(func|class|data|meth|attr|mod|obj|exc|const|math):`([^`]+)`")
MATH_DIRECTIVE_RE = re.compile(r"^(?P<indent>[ \t]*)\.\. math::[ \t]*(?P<rest>.*)$")
DOCS_API = Path(__file__).resolve().parent.parent / "docs" / "api"


def documented_modules(api_dir: Path = DOCS_API) -> set[str]:
    """The module paths rendered by ``::: module`` lines of the API pages."""
    mods = set()
    for page in api_dir.glob("*.md"):
        for line in page.read_text(encoding="utf-8").splitlines():
            if line.startswith(":::"):
                mods.add(line[3:].strip().split()[0])
    return mods


def _convert_math_blocks(text: str) -> str:
    """``.. math::`` directives (one-line or indented body) → ``$$`` blocks."""
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        m = MATH_DIRECTIVE_RE.match(lines[i])
        if not m:
            out.append(lines[i])
            i += 1
            continue
        indent = m.group("indent")
        body = [m.group("rest")] if m.group("rest").strip() else []
        i += 1
        # body: following lines indented deeper than the directive, or blank
        while i < len(lines):
            line = lines[i]
            if line.strip() == "":
                if body and i + 1 < len(lines) and not _deeper(lines[i + 1], indent):
                    break
                i += 1
                continue
            if not _deeper(line, indent):
                break
            body.append(line.strip())
            i += 1
        if out and out[-1].strip():
            out.append("")
        out.extend([f"{indent}$$", *[f"{indent}{b}" for b in body], f"{indent}$$", ""])
    return "\n".join(out)


_LIST_SECTIONS = ("Public objects", "Modules")
_DASHES = re.compile(r"\s*-{3,}\s*")


def _definition_lists(text: str) -> str:
    """Term/description pairs of the "Public objects" / "Modules" sections → a bullet list.

    numpy style writes them like ``Parameters`` entries without types (a name at the margin,
    the description indented below), which Markdown would run together into one paragraph.
    Names become ``:obj:`` roles, so they link to the objects.
    """
    lines = text.split("\n")
    in_list = False
    for i, line in enumerate(lines):
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and _DASHES.fullmatch(nxt):
            in_list = line.strip() in _LIST_SECTIONS
            continue
        if (in_list and line.strip() and not line[0].isspace() and not _DASHES.fullmatch(line)
                and nxt[:1].isspace() and nxt.strip()):
            terms = [t.strip() for t in line.split(",")]
            if all(re.fullmatch(r"[A-Za-z_][\w.]*", t) for t in terms):
                line = ", ".join(f":obj:`{t}`" for t in terms)
            lines[i] = f"- {line} —"
    return "\n".join(lines)


def _deeper(line: str, indent: str) -> bool:
    return len(line) - len(line.lstrip()) > len(indent) and bool(line.strip())


def _literal_markers(text: str) -> str:
    """reST ``text::`` before an indented block → ``text:``; a lone ``::`` line is dropped."""
    text = re.sub(r"(?m)^[ \t]*::[ \t]*$\n?", "", text)
    return re.sub(r"(?m)(\S)::[ \t]*$", r"\1:", text)


class _Resolver:
    """Finds the object a role names, the way Sphinx would, and whether the site renders it."""

    def __init__(self, pkg, documented: set[str]):
        self.pkg = pkg
        self.documented = documented
        self.by_name: dict = {}
        self.reexports: dict = {}  # path of an object in a private module -> its re-export
        self._index(pkg)

    def _index(self, mod) -> None:
        for name, member in mod.members.items():
            if member.is_alias:
                self._index_reexport(mod, member)
                continue
            if member.is_module:
                self._index(member)
            elif not name.startswith("_"):
                self.by_name.setdefault(name, member)

    def _index_reexport(self, mod, alias) -> None:
        """Record ``alias`` if a documented module exports it (``__all__``): mkdocstrings
        renders it there, under the re-export's path, so links to its target go there."""
        if mod.path not in self.documented or not alias.is_exported:
            return
        try:
            target = alias.final_target
        except Exception:  # noqa: BLE001 — unresolvable alias (external, wildcard)
            return
        self.reexports.setdefault(target.path, alias)

    def _lookup(self, path: str):
        parts = path.split(".")
        if parts[0] != self.pkg.name:
            return None
        obj = self.pkg
        for part in parts[1:]:
            try:
                obj = obj.members[part]
            except (KeyError, AttributeError):
                return None
            if obj.is_alias:
                try:
                    obj = obj.final_target
                except Exception:  # noqa: BLE001 — unresolvable alias (external, wildcard)
                    return None
        return obj

    def resolve(self, target: str, scope):
        """Object named ``target`` from the docstring of ``scope`` (or None); an object of a
        private module is replaced by its documented re-export, if there is one."""
        found = self._resolve(target, scope)
        if found is not None and not self.rendered(found):
            return self.reexports.get(found.path, found)
        return found

    def _resolve(self, target: str, scope):
        if target.startswith("."):  # relative to the current module's package
            mod = scope if scope.is_module else scope.module
            base = mod.path if mod.is_package else mod.path.rsplit(".", 1)[0]
            return self._lookup(base + target)
        obj = scope
        while obj is not None:  # the scope, its parents, ..., the package
            found = self._lookup(f"{obj.path}.{target}")
            if found is not None:
                return found
            obj = obj.parent
        found = self._lookup(target)
        if found is not None:
            return found
        first, _, rest = target.removeprefix(f"{self.pkg.name}.").partition(".")
        found = self.by_name.get(first)
        if found is not None and rest:
            found = self._lookup(f"{found.path}.{rest}")
        return found

    def rendered(self, obj) -> bool:
        """True if the API reference has an anchor for ``obj`` (so autorefs can link to it)."""
        path = obj.path
        if any(p.startswith("_") and not (p.startswith("__") and p.endswith("__"))
               for p in path.split(".")):
            return False
        if obj.is_alias:  # a re-export: rendered by the module whose __all__ lists it
            return obj.parent.path in self.documented and obj.is_exported and bool(obj.docstring)
        if obj.is_module:
            return path in self.documented
        if obj.module.path not in self.documented:
            return False
        return bool(obj.docstring) and (obj.parent.is_module or self.rendered(obj.parent))


def convert(text: str, scope=None, resolver: _Resolver | None = None) -> str:
    """Translate the reST markup of one docstring to Markdown (see the module docstring)."""
    text = _definition_lists(_convert_math_blocks(text))

    def role(m: re.Match) -> str:
        kind, content = m.group(1), m.group(2)
        if kind == "math":
            return f"${content}$"
        explicit = re.fullmatch(r"(.*?)\s*<([^>]+)>", content)
        if explicit:
            title, target = explicit.group(1), explicit.group(2)
        else:
            target = content.lstrip("!~")
            title = target.rsplit(".", 1)[-1] if content.startswith("~") else target
        if kind in ("func", "meth") and not title.endswith(")"):
            title += "()"
        if content.startswith("!") or resolver is None or scope is None:
            return f"`{title}`"
        obj = resolver.resolve(target, scope)
        if obj is not None and obj.is_module and kind != "mod" and obj.name in obj.members:
            # a package re-exporting a function named like its module (``atmoscatter.plan`` is
            # ``atmoscatter.render.plan.plan``): Griffe keeps the submodule under that name
            obj = obj.members[obj.name]
            if obj.is_alias:
                try:
                    obj = obj.final_target
                except Exception:  # noqa: BLE001 — unresolvable alias
                    obj = None
        if obj is None or not resolver.rendered(obj):
            return f"`{title}`"
        return f"[`{title}`][{obj.path}]"

    text = ROLE_RE.sub(role, text)
    return _literal_markers(text)


try:  # the Griffe extension (griffe is installed with the docs extra)
    import griffe
except ImportError:  # pragma: no cover — the script mode needs no griffe
    griffe = None

if griffe is not None:

    class SphinxRoles(griffe.Extension):
        """Griffe extension: rewrite every docstring of the package once it is loaded."""

        def on_package(self, *, pkg, loader, **kwargs) -> None:  # noqa: ARG002
            resolver = _Resolver(pkg, documented_modules())
            self._walk(pkg, resolver)

        def _walk(self, obj, resolver) -> None:
            if obj.docstring is not None:
                obj.docstring.value = convert(obj.docstring.value, obj, resolver)
            for member in obj.members.values():
                if not member.is_alias:
                    self._walk(member, resolver)


def main(argv: list[str]) -> int:
    """List raw roles / math directives per file; exit status 0 (informational)."""
    total = 0
    for name in argv:
        text = Path(name).read_text(encoding="utf-8")
        n = len(ROLE_RE.findall(text)) + len(re.findall(r"\.\. math::", text))
        total += n
        if n:
            print(f"{name}: {n}")
    print(f"{total} reST roles/directives (rendered by the Griffe extension at docs build time)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
