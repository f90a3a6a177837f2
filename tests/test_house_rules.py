"""The house rules of the code (issue 46): no module over MODULE_LINES lines, no function over
FUNCTION_LINES lines, no import cycle among the slipnav modules (their module-level imports), the
linter's rules in pyproject.toml, and docs that state behaviour: no "before -> after" figure in a
docstring, a comment, the README or docs/ (measured figures: docs/results.md)."""

import ast
import io
import re
import shutil
import subprocess
import sys
import tokenize
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


BEFORE_AFTER = re.compile(r"\d[\d.,]*\s*(?:%|[a-zA-Z/°]+)?\s*(?:->|→)\s*\d")
"""A measured "before -> after" figure: a number (a unit may follow), an arrow, a number. A mapping has
no number on both sides of its arrow ("fault class -> its schema kind"), and a parameter's effect reads
as behaviour ("0.99: a time constant of 0.2 s")."""
GENERATED_DOCS = ("docs/results.md", "docs/scenario-schema.md")
"""Pages written by commands (slipnav results; python -m slipnav.scenarios.schema from the field docs)."""


def _prose(text: str):
    """(first line, text) of every docstring and comment of a module's source: the strings that stand
    alone as statements (module, class, function and attribute docstrings, the field docs in them),
    whole, so that a figure wrapped over two lines counts, and the comments."""
    for node in ast.walk(ast.parse(text)):
        if (
            isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
        ):
            yield node.value.lineno, node.value.value
    for token in tokenize.generate_tokens(io.StringIO(text).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string


def _before_after(name: str, prose) -> list[str]:
    """``name:line: the line`` of every line with a BEFORE_AFTER match in ``prose``'s (first line, text)
    pairs."""
    found = set()
    for first, text in prose:
        for match in BEFORE_AFTER.finditer(text):
            offset = text.count("\n", 0, match.start())
            found.add((first + offset, text.split("\n")[offset].strip()))
    return [f"{name}:{line}: {text}" for line, text in sorted(found)]


def _module_before_after(module: str) -> list[str]:
    text = (ROOT / module).read_text()
    if not (BEFORE_AFTER.search(text) or "\\u2192" in text or "\\N{" in text):
        return []  # no candidate in the source, whose docstrings are its text (escapes aside)
    return _before_after(module, _prose(text))


def test_the_before_after_check_finds_measured_history_and_spares_mappings():
    """The check names the line of each measured figure, one wrapped over two lines of a docstring too,
    and none of the arrows that map: a type hint, equations, a chain of blocks, an effect as behaviour."""
    source = (
        '"""Tuned (closed loop 78/83 -> 78/78 episodes); open loop 1.17 -> 0.49 deg."""\n'
        "GAIN = 0.7  # error 26 -> 8 mm/s, 10 seeds\n"
        'LIMIT = 2\n"""The long path 0.9-2.3 % -> 0.1-0.5 %, side slip 2.82 → 2.07 deg."""\n\n\n'
        "def kind(fault: str, n: int = 3) -> int:\n"
        '    """Fault class -> its schema kind; S(11) -> S(12); 0.99: a time constant of 0.2 s.\n\n'
        '    On the square 1.2 ->\n    0.5 %: wrapped."""\n'
        '    return {"bias": 1}[fault] + n  # navigation -> follower -> plant\n'
    )
    hits = _before_after("m.py", _prose(source))
    assert [hit.split(":")[1] for hit in hits] == ["1", "2", "4", "10"], hits
    assert hits[-1] == "m.py:10: On the square 1.2 ->"


def test_docstrings_comments_and_docs_state_behaviour_not_before_after_figures():
    """The house rule: docs and comments state behaviour, units and ranges in the present tense; measured
    figures live in docs/results.md (slipnav results) and their history in the commit messages."""
    found = [hit for module in MODULES for hit in _module_before_after(module)]
    documents = ["README.md", *(path.relative_to(ROOT).as_posix() for path in (ROOT / "docs").glob("*.md"))]
    for document in sorted(set(documents) - set(GENERATED_DOCS)):
        found += _before_after(document, [(1, (ROOT / document).read_text())])
    assert not found, (
        "a before -> after figure (state the behaviour; figures: docs/results.md):\n" + "\n".join(found)
    )
