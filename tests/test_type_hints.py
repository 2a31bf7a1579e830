"""Every public function of render/ and train/ carries type hints (docs/architecture.md).

Public: module-level functions and the methods of module-level classes whose names do not start
with an underscore, ``__init__`` included (its parameters; it returns None). Every parameter but
``self`` and ``cls`` is annotated, and so is the return. Read from the source with ``ast``.
"""

import ast

from tests.conftest import REPO

PACKAGES = ("render", "train")


def public_functions(tree):
    """(qualified name, function node) of the public functions of a module's ``tree``."""
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if not node.name.startswith("_"):
                yield node.name, node
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) and (
                        item.name == "__init__" or not item.name.startswith("_")):
                    yield f"{node.name}.{item.name}", item


def missing_hints(function):
    """Names of the parameters of ``function`` without an annotation, and 'return' when the
    return is not annotated (``__init__`` excepted)."""
    arguments = function.args
    parameters = arguments.posonlyargs + arguments.args + arguments.kwonlyargs
    parameters += [p for p in (arguments.vararg, arguments.kwarg) if p is not None]
    missing = [p.arg for p in parameters if p.annotation is None and p.arg not in ("self", "cls")]
    if function.returns is None and function.name != "__init__":
        missing.append("return")
    return missing


def unannotated():
    """'path:line name (what is missing)' for every public function lacking a hint."""
    found = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            for name, function in public_functions(tree):
                missing = missing_hints(function)
                if missing:
                    found.append(f"{path.relative_to(REPO)}:{function.lineno} {name} "
                                 f"({', '.join(missing)})")
    return found


def test_missing_hints_are_found():
    tree = ast.parse("def f(a, b: int) -> int: ...\n"
                     "def g(a: int): ...\n"
                     "def _private(a): ...\n"
                     "class C:\n"
                     "    def __init__(self, x): ...\n"
                     "    def m(self, *args: int, **kw) -> None: ...\n"
                     "    def _p(self, y): ...\n")
    found = {name: missing_hints(function) for name, function in public_functions(tree)}
    assert found == {"f": ["a"], "g": ["return"], "C.__init__": ["x"], "C.m": ["kw"]}


def test_every_public_function_has_type_hints():
    missing = unannotated()
    assert not missing, f"{len(missing)} public functions without full type hints:\n" + \
        "\n".join(missing)
