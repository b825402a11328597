"""The size rules of issue #37 for gyrocomp/diagnose/: no module over 500 lines, no function over 80 lines of code, diagnose() on one screen."""

import ast
import io
import tokenize
from pathlib import Path

import pytest

import gyrocomp.diagnose

PACKAGE = Path(gyrocomp.diagnose.__file__).parent
MODULES = sorted(PACKAGE.rglob("*.py"))
MAX_MODULE_LINES = 500
MAX_FUNCTION_CODE = 80
MAX_DIAGNOSE_CODE = 50


def code_lines(source: str, node: ast.AST) -> int:
    """Lines of `node` that hold code: not blank, not only a comment, not its docstring (nor a nested one's)."""
    docs = set()
    for inner in ast.walk(node):
        if isinstance(inner, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Module)) and ast.get_docstring(inner, clean=False):
            doc = inner.body[0]
            docs.update(range(doc.lineno, doc.end_lineno + 1))
    lines = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER):
            continue
        for line in range(tok.start[0], tok.end[0] + 1):
            if node.lineno <= line <= node.end_lineno and line not in docs:
                lines.add(line)
    return len(lines)


def functions(path):
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node, code_lines(source, node)


def test_code_lines_leave_out_docstrings_comments_and_blank_lines():
    source = 'def f(x):\n    """Doc.\n\n    More.\n    """\n    # a comment\n\n    y = (x +\n         1)\n    return y\n'
    (node, n), = functions_of(source)
    assert n == 4  # def, y = (x +, 1), return


def functions_of(source):
    tree = ast.parse(source)
    return [(node, code_lines(source, node)) for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_is_over_500_lines(path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_MODULE_LINES, f"{path.name}: {n} lines"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_function_is_over_80_lines_of_code(path):
    long = {f"{node.name} (line {node.lineno})": n for node, n in functions(path) if n > MAX_FUNCTION_CODE}
    assert not long, f"{path.name}: {long}"


def test_diagnose_fits_on_one_screen():
    (n,) = [n for node, n in functions(PACKAGE / "__init__.py") if node.name == "diagnose"]
    assert n <= MAX_DIAGNOSE_CODE, f"diagnose(): {n} lines of code"
