"""The house rules of the code (issue 46): no module over MODULE_LINES lines, no function over
FUNCTION_LINES lines, no import cycle among the slipnav modules (their module-level imports), and the
linter's rules in pyproject.toml."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("systems", "diagrams", "scenarios", "studies")
"""The folders that install as slipnav.<folder> (pyproject.toml)."""
MODULE_LINES = 500
FUNCTION_LINES = 100

MODULES = sorted(
    path.relative_to(ROOT).as_posix() for folder in PACKAGES for path in (ROOT / folder).rglob("*.py")
)


def _functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


@pytest.mark.parametrize("module", MODULES)
def test_modules_and_functions_are_within_the_size_limits(module):
    text = (ROOT / module).read_text()
    assert text.count("\n") <= MODULE_LINES, f"{module}: {text.count(chr(10))} lines"
    for function in _functions(ast.parse(text)):
        length = function.end_lineno - function.lineno + 1
        assert length <= FUNCTION_LINES, f"{module}:{function.lineno} {function.name}: {length} lines"


def _module_name(module: str) -> str:
    parts = module.removesuffix(".py").split("/")
    return ".".join(["slipnav", *(parts[:-1] if parts[-1] == "__init__" else parts)])


def _module_level_imports(tree: ast.Module, package: str) -> set[str]:
    """The slipnav modules a module imports when it is imported: its top-level statements and those in
    top-level if/try blocks (not ``if TYPE_CHECKING``), not the imports inside functions."""
    found, pending = set(), list(tree.body)
    while pending:
        node = pending.pop()
        if isinstance(node, ast.If):
            if "TYPE_CHECKING" not in ast.unparse(node.test):
                pending += node.body + node.orelse
        elif isinstance(node, ast.Try):
            pending += node.body + node.orelse + node.finalbody + [s for h in node.handlers for s in h.body]
        elif isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(
                    [*package.split(".")[: len(package.split(".")) - node.level + 1], base]
                ).strip(".")
            found.add(base)
            found |= {
                f"{base}.{alias.name}" for alias in node.names
            }  # ``from slipnav.scenarios import plots``
    return found


def test_no_import_cycles_among_slipnav_modules():
    names = {_module_name(module): module for module in MODULES}
    graph = {}
    for name, module in names.items():
        imported = _module_level_imports(ast.parse((ROOT / module).read_text()), name.rsplit(".", 1)[0])
        graph[name] = sorted((imported & names.keys()) - {name})
    state, path = {}, []

    def visit(name):
        state[name] = "open"
        path.append(name)
        for target in graph[name]:
            if state.get(target) == "open":
                cycle = path[path.index(target) :] + [target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target)
        path.pop()
        state[name] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name)


def test_the_linter_holds_the_statement_and_complexity_limits():
    """pyproject.toml's ruff rules (style, imports, and per function at most 70 statements, 15 branches
    and McCabe complexity 15) hold on every folder."""
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff is not installed (pip install -e '.[test]' installs it)")
    folders = [str(ROOT / folder) for folder in (*PACKAGES, "tests")]
    result = subprocess.run([ruff, "check", *folders], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-2000:]
