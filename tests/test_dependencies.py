"""Every third-party module the toolkit and its scripts import, at any depth (inside functions too, where optional
features import lazily), comes from a distribution in pyproject.toml's ``dependencies``: the ``test`` extra must not
hide a runtime import that README command 1 (a bare ``pip install -e .``) would miss. Read from the source with
``ast``; the distributions behind a module name from the installed packages' metadata."""
import ast
import importlib.metadata
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNTIME = ("drakeslip", "planners", "verification", "examples")
OURS = {"drakeslip", "planners", "verification"}
# Modules that a distribution brings without listing them under its own name: pydrake comes with drake, and
# llvmlite is numba's own dependency, used beside it to write the compiled code's intrinsics.
PROVIDED_BY = {"pydrake": "drake", "llvmlite": "numba"}


def distribution_name(requirement: str) -> str:
    return re.split(r"[<>=!~\[;\s]", requirement, maxsplit=1)[0].strip().lower().replace("_", "-")


def declared() -> tuple[set, set]:
    """(runtime distributions, test-extra distributions) named in pyproject.toml."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    runtime = {distribution_name(r) for r in project["dependencies"]}
    test = {distribution_name(r) for r in project["optional-dependencies"]["test"]}
    return runtime, test


def third_party_imports() -> dict:
    """top-level module name -> the first 'file:line' importing it, over every runtime source."""
    found = {}
    for folder in RUNTIME:
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top not in OURS and top not in sys.stdlib_module_names and top != "__future__":
                        found.setdefault(top, f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


def distributions_of(module: str) -> set:
    if module in PROVIDED_BY:
        return {PROVIDED_BY[module]}
    return {d.lower().replace("_", "-") for d in importlib.metadata.packages_distributions().get(module, [])}


def test_every_runtime_import_is_a_declared_dependency():
    runtime, _ = declared()
    missing = [f"{module} ({where}): from {sorted(distributions_of(module)) or 'no installed distribution'}"
               for module, where in sorted(third_party_imports().items())
               if not distributions_of(module) & runtime]
    assert not missing, "imported at run time but not in pyproject's dependencies:\n" + "\n".join(missing)


def test_the_check_sees_lazy_imports_and_the_test_extra_is_for_tests_only():
    imports = third_party_imports()
    assert {"numpy", "torch", "pydrake", "numba", "scipy", "ray"} <= set(imports)   # ray and scipy: inside functions
    runtime, test = declared()
    assert {"pytest", "pytest-benchmark"} <= test and not {"pytest", "pytest-benchmark"} & runtime
    assert not {"pytest", "_pytest"} & set(imports), "runtime code imports pytest"
