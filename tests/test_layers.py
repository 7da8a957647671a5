"""The layout holds: drakeslip <- planners <- verification <- examples, no import circles, no use of another
module's private names, and small files. Read from the source with ``ast`` (nothing is imported)."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("drakeslip", "planners", "verification", "examples")  # each may import only from those before it
MAX_LINES = 400


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


SOURCES = {module_name(p): p for layer in LAYERS for p in sorted((ROOT / layer).rglob("*.py"))}


def resolve(name: str) -> str | None:
    """The module of ours ``name`` refers to (itself, or the package holding an attribute), or None."""
    while name and name not in SOURCES:
        name = name.rpartition(".")[0]
    return name or None


def imports(module: str):
    """(imported module of ours, imported names, line) for every import statement of ``module``, at any depth."""
    tree = ast.parse(SOURCES[module].read_text())
    package = module if SOURCES[module].name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                target = resolve(alias.name)
                if target:
                    yield target, [], node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1] + ([base] if base else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                if full in SOURCES:
                    yield full, [], node.lineno
                elif resolve(base):
                    yield resolve(base), [alias.name], node.lineno


def layer(module: str) -> int:
    return LAYERS.index(module.split(".")[0])


def test_no_module_imports_from_a_higher_layer():
    upward = [f"{m} (line {line}) imports {target}" for m in SOURCES for target, _, line in imports(m)
              if layer(target) > layer(m)]
    assert not upward, "\n".join(upward)


def test_no_import_circles():
    graph = {m: {target for target, _, _ in imports(m) if target != m} for m in SOURCES}
    circles, state = [], {}

    def visit(m, stack):
        state[m] = "open"
        for n in sorted(graph[m]):
            if state.get(n) == "open":
                circles.append(" -> ".join(stack[stack.index(n):] + [n]))
            elif n not in state:
                visit(n, stack + [n])
        state[m] = "done"

    for m in SOURCES:
        if m not in state:
            visit(m, [m])
    assert not circles, "\n".join(circles)


def test_no_module_uses_another_modules_private_names():
    found = []
    for m, path in SOURCES.items():
        tree = ast.parse(path.read_text())
        aliases = {}
        for target, names, line in imports(m):
            found += [f"{m} (line {line}) imports {target}.{n}" for n in names if n.startswith("_") and target != m]
        for node in ast.walk(tree):  # module aliases: import a.b as c, from a import b (a module)
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for alias in node.names:
                    full = alias.name if isinstance(node, ast.Import) else f"{node.module}.{alias.name}"
                    if full in SOURCES and full != m:
                        aliases[alias.asname or alias.name.split(".")[0]] = full
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__") \
                    and isinstance(node.value, ast.Name) and node.value.id in aliases:
                found.append(f"{m} (line {node.lineno}) uses {aliases[node.value.id]}.{node.attr}")
    assert not found, "\n".join(found)


@pytest.mark.parametrize("module", sorted(SOURCES))
def test_source_files_stay_small(module):
    lines = len(SOURCES[module].read_text().splitlines())
    assert lines <= MAX_LINES, f"{SOURCES[module].relative_to(ROOT)} has {lines} lines (at most {MAX_LINES})"


def test_the_walk_sees_a_circle_an_upward_import_and_a_private_name(tmp_path, monkeypatch):
    """The checks above can fail: a made-up package with each fault is caught."""
    for name, text in {"drakeslip/__init__.py": "", "drakeslip/a.py": "from drakeslip.b import _hidden\n",
                       "drakeslip/b.py": "import drakeslip.a\nfrom planners import x\n_hidden = 1\n",
                       "planners/__init__.py": "x = 1\n"}.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    sources = {module_name(p): p for layer_ in LAYERS for p in sorted((tmp_path / layer_).rglob("*.py"))}
    monkeypatch.setattr(__import__(__name__), "SOURCES", sources)
    for check in (test_no_module_imports_from_a_higher_layer, test_no_import_circles,
                  test_no_module_uses_another_modules_private_names):
        with pytest.raises(AssertionError):
            check()
