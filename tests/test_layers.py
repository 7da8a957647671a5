"""The layout holds, read from the source with ``ast`` (nothing is imported). Every import counts, at module level
or inside a function.

* Layers: drakeslip <- planners <- verification <- examples; each imports only from those before it.
* No import circles: between modules, and between the parts of one package (its subpackages and modules): the
  parts of each package import one way, so none imports back up into a part that imports it (planners/search and
  planners/core, drakeslip/jobs and drakeslip/hopper_file). No module imports a package that holds it (that
  package's ``__init__`` imports its parts, so such an import runs back up too).
* The job infrastructure (drakeslip/jobs: argument types, executors, atomic writes, pipelines) imports nothing of
  ours outside itself, so the physics can use it and never the other way round.
* No use of another module's private (underscore) names; no file over 400 lines; no line over 120 characters.
* No function over 60 lines or 8 parameters (``self`` and ``cls`` not counted) without its reason in a comment on
  its ``def`` line or the line before it (or before its first decorator): ``# long: WHY`` for the length,
  ``# many parameters: WHY`` for the parameters, e.g. ``# many parameters: numba compiles positional arrays``.
"""
import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("drakeslip", "planners", "verification", "examples")  # each may import only from those before it
INFRASTRUCTURE = "drakeslip.jobs"
MAX_LINES, MAX_LINE_LENGTH, MAX_FUNCTION_LINES, MAX_PARAMETERS = 400, 120, 60, 8
LONG_REASON, MANY_PARAMETERS_REASON = re.compile(r"#\s*long:\s*\S"), re.compile(r"#\s*many parameters:\s*\S")


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
                kept = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(kept + ([base] if base else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                if full in SOURCES:
                    yield full, [], node.lineno
                elif resolve(base):
                    yield resolve(base), [alias.name], node.lineno


def layer(module: str) -> int:
    return LAYERS.index(module.split(".")[0])


def inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def part_imports() -> dict:
    """{(package, part, other part): ["module (line N) imports module", ...]}: every import between two parts
    (subpackages or modules) of one package."""
    found = {}
    for m in SOURCES:
        for target, _, line in imports(m):
            mine, theirs = m.split("."), target.split(".")
            common = next((k for k, (a, b) in enumerate(zip(mine, theirs)) if a != b), min(len(mine), len(theirs)))
            if common < min(len(mine), len(theirs)):
                key = (".".join(mine[:common]), mine[common], theirs[common])
                found.setdefault(key, set()).add(f"{m} (line {line}) imports {target}")
    return {key: sorted(lines) for key, lines in found.items()}


def circles(graph: dict) -> list[frozenset]:
    """The strongly connected parts of more than one node of ``graph`` (node -> nodes it points to)."""
    reach = {}

    def reached(start):
        seen, todo = set(), [start]
        while todo:
            for n in graph.get(todo.pop(), ()):
                if n not in seen:
                    seen.add(n)
                    todo.append(n)
        return seen

    for node in graph:
        reach[node] = reached(node)
    found = {frozenset(n for n in reach[node] if node in reach.get(n, ())) | {node} for node in graph}
    return sorted((c for c in found if len(c) > 1), key=sorted)


def part_circles() -> list[tuple[str, frozenset, list]]:
    """(package, its parts that import each other in a circle, the imports between them) for each such circle."""
    edges = part_imports()
    graphs = {}
    for package, part, other in edges:
        graphs.setdefault(package, {}).setdefault(part, set()).add(other)
    found = []
    for package, graph in sorted(graphs.items()):
        for circle in circles(graph):
            found.append((package, circle, [line for (p, a, b), lines in sorted(edges.items())
                                            if p == package and a in circle and b in circle for line in lines]))
    return found


def show(circle_list) -> str:
    return "\n".join(f"{package or '(top)'}: {', '.join(sorted(parts))} import each other:\n  " + "\n  ".join(lines)
                     for package, parts, lines in circle_list)


def test_no_module_imports_from_a_higher_layer():
    upward = [f"{m} (line {line}) imports {target}" for m in SOURCES for target, _, line in imports(m)
              if layer(target) > layer(m)]
    assert not upward, "\n".join(upward)


def test_no_import_circles():
    graph = {m: {target for target, _, _ in imports(m) if target != m} for m in SOURCES}
    found, state = [], {}

    def visit(m, stack):
        state[m] = "open"
        for n in sorted(graph[m]):
            if state.get(n) == "open":
                found.append(" -> ".join(stack[stack.index(n):] + [n]))
            elif n not in state:
                visit(n, stack + [n])
        state[m] = "done"

    for m in SOURCES:
        if m not in state:
            visit(m, [m])
    assert not found, "\n".join(found)


def test_the_parts_of_each_package_import_one_way():
    found = part_circles()
    assert not found, show(found)


def test_no_module_imports_a_package_that_holds_it():
    found = sorted({f"{m} (line {line}) imports {target}" for m in SOURCES for target, _, line in imports(m)
                    if target != m and inside(m, target)})
    assert not found, "\n".join(found)


def test_the_job_infrastructure_imports_nothing_of_the_physics():
    found = sorted({f"{m} (line {line}) imports {target}" for m in SOURCES if inside(m, INFRASTRUCTURE)
                    for target, _, line in imports(m) if not inside(target, INFRASTRUCTURE)})
    assert not found, "\n".join(found)


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


def long_lines() -> list[str]:
    return [f"{path.relative_to(ROOT)}:{n}: {len(line)} characters" for path in SOURCES.values()
            for n, line in enumerate(path.read_text().splitlines(), 1) if len(line) > MAX_LINE_LENGTH]


def unexplained_functions() -> list[str]:
    """'FILE:LINE NAME: N lines' / ': N parameters' for each function over a limit without its reason comment."""
    found = []
    for path in SOURCES.values():
        text = path.read_text().splitlines()
        for node in ast.walk(ast.parse("\n".join(text))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            top = min([node.lineno] + [d.lineno for d in node.decorator_list])
            comments = " ".join(text[n - 1] for n in {node.lineno, node.lineno - 1, top - 1} if n >= 1)
            length = node.end_lineno - node.lineno + 1
            args = node.args
            names = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs, args.vararg, args.kwarg) if a]
            count = len([name for name in names if name not in ("self", "cls")])
            where = f"{path.relative_to(ROOT)}:{node.lineno} {node.name}"
            if length > MAX_FUNCTION_LINES and not LONG_REASON.search(comments):
                found.append(f"{where}: {length} lines")
            if count > MAX_PARAMETERS and not MANY_PARAMETERS_REASON.search(comments):
                found.append(f"{where}: {count} parameters")
    return found


def test_no_line_is_over_120_characters():
    found = long_lines()
    assert not found, f"{len(found)} lines:\n" + "\n".join(found)


def test_no_long_function_without_its_reason():
    found = unexplained_functions()
    assert not found, f"{len(found)} functions:\n" + "\n".join(found)


CHECKS = (test_no_module_imports_from_a_higher_layer, test_no_import_circles,
          test_the_parts_of_each_package_import_one_way,
          test_no_module_imports_a_package_that_holds_it, test_the_job_infrastructure_imports_nothing_of_the_physics,
          test_no_module_uses_another_modules_private_names, test_no_line_is_over_120_characters,
          test_no_long_function_without_its_reason)
BODY = "    pass\n" * MAX_FUNCTION_LINES
CLEAN = {  # one-way parts; a long function and a function of many parameters, each with its reason
    "drakeslip/__init__.py": "", "drakeslip/jobs/__init__.py": "", "drakeslip/jobs/run.py": "import os\n",
    "drakeslip/a.py": "from drakeslip.jobs import run\n\n\ndef f():\n    from drakeslip import b\n",
    "drakeslip/b.py": f"# long: a test of the reason\ndef f():\n{BODY}\n\n@staticmethod\n"
                      f"def g(a, b, c, d, e, f, g, h, i):  # many parameters: a test of the reason\n    pass\n",
    "planners/__init__.py": "from planners import core\n", "planners/core/__init__.py": "",
    "planners/search/__init__.py": "from planners.core import x\n", "planners/core/x.py": "",
}
FAULTY = {  # each check's fault, the imports inside functions too
    **CLEAN, "drakeslip/a.py": "from drakeslip.b import _hidden\n",
    "drakeslip/b.py": "import drakeslip.a\n_hidden = 1\n",
    "drakeslip/c.py": "from planners import core\n\n\ndef f():\n    from drakeslip.jobs import files\n",
    "drakeslip/jobs/files.py": "",
    "drakeslip/jobs/run.py": "def f():\n    import drakeslip.c\n    import drakeslip.jobs\n",
    "planners/core/x.py": "x = 1  # " + "." * MAX_LINE_LENGTH + "\n\n\ndef f():\n    from planners.search import y\n",
    "planners/search/y.py": f"def f(a, b, c, d, e, f, g, h, i):\n{BODY}",
}


@pytest.mark.parametrize("tree, fails", [(CLEAN, ()), (FAULTY, CHECKS)], ids=["clean", "faulty"])
def test_the_checks_see_each_fault(tmp_path, monkeypatch, tree, fails):
    """The checks above can fail, each on a made-up tree with its fault, and pass on one without."""
    for name, text in tree.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    sources = {module_name(p): p for layer_ in LAYERS for p in sorted((tmp_path / layer_).rglob("*.py"))}
    monkeypatch.setattr(__import__(__name__), "SOURCES", sources)
    passed = []
    for check in CHECKS:
        try:
            check()
            passed.append(check.__name__)
        except AssertionError:
            pass
    assert passed == [check.__name__ for check in CHECKS if check not in fails]
