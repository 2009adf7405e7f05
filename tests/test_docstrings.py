"""Every public function of ced has a numpy-style docstring (docs/api is built from them):
a summary, and a ``Parameters`` section when it takes arguments."""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "ced"

#: Layers being rewritten on another branch; their docstrings are brought to this rule there.
#: Remove an entry once its modules pass.
PENDING = ()


def public_functions():
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative.startswith(PENDING):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = None
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__"
                                                    for t in node.targets):
                names = set(ast.literal_eval(node.value))
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) \
                    and not node.name.startswith("_") and (names is None or node.name in names):
                yield f"{relative}::{node.name}", node


def test_every_public_function_has_a_numpy_docstring():
    bad = []
    for where, node in public_functions():
        doc = ast.get_docstring(node)
        if not doc:
            bad.append(f"{where}: no docstring")
        elif isinstance(node, ast.FunctionDef) and (node.args.args or node.args.kwonlyargs) \
                and "Parameters\n----------" not in doc:
            bad.append(f"{where}: no Parameters section")
    assert not bad, "\n".join(bad)
