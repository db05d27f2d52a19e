"""The package's layers, checked from the source.

``docs/architecture.md`` draws the packages as layers; this test reads every module's
``import`` statements (with :mod:`ast`, so nothing is imported) and fails if a module imports
one from a higher layer — including imports deferred into a function body, which are still a
dependency — or if the top-level imports of the package form a cycle.

The layers, low to high (a module may import from its own layer or below):

0. base: the shared argument checks and small utilities (``_validate``, ``_lazy``,
   ``_progress``, ``_atomic``);
1. physics: phase functions, scattering coefficients, density profiles, atmospheres and
   presets, geometry and optical length, the solar spectrum, colour, the field cache, and the
   ``sun`` package;
2. ``sky``: the sky models;
3. ``convergence``: the error-against-run-time study of the sky models;
4. ``scene`` (what a user sets; it validates the model name against the registry of
   :mod:`atmoscatter.render.models`, hence the shared layer) and ``render``: plan,
   directions, model adapters, evaluator, image; ``integrals`` of a rendered sky;
5. files: ``exr``, ``preview``, ``compare``;
6. applications: ``batch``, ``cli``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "atmoscatter"

# first dotted component below ``atmoscatter`` -> layer
LAYERS = {
    "_validate": 0,
    "_lazy": 0,
    "_progress": 0,
    "_atomic": 0,
    "phase": 1,
    "scattering": 1,
    "profiles": 1,
    "atmosphere": 1,
    "presets": 1,
    "standard_atmosphere": 1,
    "geometry": 1,
    "optical_length": 1,
    "solar": 1,
    "colour": 1,
    "cache": 1,
    "sun": 1,
    "sky": 2,
    "convergence": 3,
    "scene": 4,
    "_scene_checks": 4,
    "render": 4,
    "integrals": 4,
    "exr": 5,
    "preview": 5,
    "compare": 5,
    "batch": 6,
    "cli": 6,
    "__main__": 6,
}


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        yield ".".join(parts), path, is_pkg


def _imports(name, path, is_pkg):
    """``(imported module, lineno, at top level)`` for every import in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if is_pkg else name.rpartition(".")[0]
    top = set(id(n) for n in tree.body)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno, id(node) in top
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if node.module is None or node.level:
                # ``from . import x`` may name submodules: record each
                for alias in node.names:
                    yield f"{mod}.{alias.name}", node.lineno, id(node) in top
            yield mod, node.lineno, id(node) in top


def _layer(module):
    parts = module.split(".")
    if parts[0] != "atmoscatter" or len(parts) == 1:
        return None
    key = parts[1]
    if key not in LAYERS:
        # a name imported from the package root (``from . import x``) that is not a module
        return None
    return LAYERS[key]


MODULES = list(_modules())


def test_every_module_has_a_layer():
    missing = sorted(
        n for n, _, _ in MODULES if n != "atmoscatter" and n.split(".")[1] not in LAYERS
    )
    assert not missing, f"modules with no layer in tests/test_architecture.py: {missing}"


@pytest.mark.parametrize("name,path,is_pkg", MODULES, ids=[m[0] for m in MODULES])
def test_no_module_imports_a_higher_layer(name, path, is_pkg):
    if name == "atmoscatter":  # the public face re-exports everything
        return
    own = _layer(name)
    bad = []
    for mod, line, _ in _imports(name, path, is_pkg):
        other = _layer(mod)
        if other is not None and other > own:
            bad.append(f"{path.name}:{line} imports {mod} (layer {other} > {own})")
    assert not bad, "\n".join(bad)


def test_top_level_imports_have_no_cycle():
    names = {n for n, _, _ in MODULES}
    graph = {}
    for name, path, is_pkg in MODULES:
        deps = set()
        for mod, _, at_top in _imports(name, path, is_pkg):
            if at_top and mod in names and mod != name:
                deps.add(mod)
        graph[name] = deps
    # a package imports its submodules to re-export them; a submodule importing its own
    # package's face would be the cycle, so drop parent -> child edges before searching
    for name in graph:
        graph[name] = {d for d in graph[name] if not d.startswith(name + ".")}
    state, stack, cycles = {}, [], []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for d in sorted(graph.get(n, ())):
            if state.get(d) == 1:
                cycles.append(stack[stack.index(d):] + [d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_the_checker_sees_a_violation(tmp_path):
    """The checker is able to fail: a physics module importing the CLI is caught."""
    fake = tmp_path / "atmoscatter" / "phase.py"
    fake.parent.mkdir()
    fake.write_text("def f():\n    from .cli import main\n", encoding="utf-8")
    found = [(m, _layer(m)) for m, _, _ in _imports("atmoscatter.phase", fake, False)]
    assert ("atmoscatter.cli", 6) in found


def test_no_module_is_long_without_saying_why():
    """Modules stay under ~500 lines unless their docstring says why they are one piece."""
    long = []
    for name, path, _ in MODULES:
        lines = path.read_text(encoding="utf-8").count("\n")
        if lines > 550:
            doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
            if "indivisible" not in doc.lower() and "one piece" not in doc.lower():
                long.append(f"{name} ({lines} lines)")
    assert not long, f"modules over ~500 lines without a reason in their docstring: {long}"


def test_reexported_names_are_unambiguous():
    """Two modules re-exported by ``atmoscatter`` may share a name only for the same object
    (a later star import would silently shadow the earlier one: ``ac.SOLAR_CONSTANT`` once
    became the Perez model's 1367 W m⁻² instead of the shipped spectrum's integral)."""
    import importlib

    import atmoscatter

    seen, clashes = {}, []
    for m in atmoscatter._REEXPORTED:
        mod = importlib.import_module(f"atmoscatter.{m}")
        for n in mod.__all__:
            obj = getattr(mod, n)
            if n in seen and seen[n][1] is not obj:
                clashes.append(f"{n}: {seen[n][0]} and {m}")
            seen.setdefault(n, (m, obj))
    assert not clashes, clashes
