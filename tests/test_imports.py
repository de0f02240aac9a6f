"""No import cycles inside torqueopt: every module's module-level imports, walked with ``ast``, form no loop.

An import inside a function runs when the function is called, not when the module loads, so it does not count;
nor do those under ``if TYPE_CHECKING:`` (never run) or ``if __name__ == "__main__":`` (run only as a script).
Every other import statement does (under ``if``, ``try``, ``with``, in a class body: they run at import time).
A second test counts the imports inside functions too: the layers import one way even where an import waits.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "torqueopt"


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _never_on_import(node: ast.AST) -> bool:
    """``if TYPE_CHECKING:`` and ``if __name__ == "__main__":``."""
    if not isinstance(node, ast.If):
        return False
    test = ast.unparse(node.test)
    return test in ("TYPE_CHECKING", "typing.TYPE_CHECKING") or test.replace("'", '"') == '__name__ == "__main__"'


def module_level_imports(tree: ast.Module, functions: bool = False) -> list[ast.Import | ast.ImportFrom]:
    """The import statements that run when the module is loaded (with ``functions``, those inside functions too)."""
    found = []
    pending = list(tree.body)
    while pending:
        node = pending.pop()
        if _never_on_import(node):
            pending.extend(node.orelse)
            continue
        if not functions and isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append(node)
        pending.extend(ast.iter_child_nodes(node))
    return found


def imported_modules(name: str, is_package: bool, node: ast.Import | ast.ImportFrom, modules: set[str]) -> set[str]:
    """The torqueopt modules ``node`` (in module ``name``) loads: each named module; for ``from X import y``, the
    submodule X.y when y is one, else X."""
    if isinstance(node, ast.Import):
        targets = {alias.name for alias in node.names}
    else:
        if node.level:
            base = name.split(".") if is_package else name.split(".")[:-1]
            base = base[: len(base) - (node.level - 1)]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        targets = {f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source for alias in node.names}
    return {target for target in targets if target in modules}


def import_graph(functions: bool = False) -> dict[str, set[str]]:
    """``{module: the torqueopt modules it imports}`` over every module of the package."""
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    graph = {}
    for path in paths:
        name = module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        edges = set()
        for node in module_level_imports(tree, functions):
            edges |= imported_modules(name, path.name == "__init__.py", node, modules)
        graph[name] = edges - {name}
    return graph


def cycles(graph: dict[str, set[str]]) -> set[tuple[str, ...]]:
    """The strongly connected components of more than one module (Tarjan), each as its sorted modules."""
    index, low, stack, on_stack, found = {}, {}, [], set(), set()

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph[node]):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.add(tuple(sorted(component)))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_walker_sees_a_cycle_made_on_purpose():
    """The walker itself: relative imports resolved (one and two dots, from a package and from a module), an
    import inside a function left out."""
    graph = {}
    sources = {
        "torqueopt.a": ("from .b import x\n", False),
        "torqueopt.b": ("def f():\n    from . import a\n", False),
        "torqueopt.sub": ("from ..b import x\nfrom . import c\n", True),
        "torqueopt.sub.c": ("if True:\n    from .. import sub\nif TYPE_CHECKING:\n    from .. import a\n", False),
    }
    for name, (text, is_package) in sources.items():
        graph[name] = set().union(
            *(imported_modules(name, is_package, node, set(sources)) for node in module_level_imports(ast.parse(text)))
        ) - {name}
    assert graph == {
        "torqueopt.a": {"torqueopt.b"},
        "torqueopt.b": set(),
        "torqueopt.sub": {"torqueopt.b", "torqueopt.sub.c"},
        "torqueopt.sub.c": {"torqueopt.sub"},
    }
    assert cycles(graph) == {("torqueopt.sub", "torqueopt.sub.c")}
    inside = module_level_imports(ast.parse(sources["torqueopt.b"][0]), functions=True)
    assert imported_modules("torqueopt.b", False, inside[0], set(sources)) == {"torqueopt.a"}


def test_no_import_cycle_at_module_level():
    """What runs when a module loads never loops back."""
    assert cycles(import_graph()) == set()


def test_no_import_cycle_even_inside_functions():
    """The layers import one way, also where an import waits inside a function (there were nine such loops:
    ``atlas`` <-> ``arms`` <-> ``frontier`` <-> ``prefix`` <-> ``report``, ``sweep`` <-> ``global_optimum``,
    ``result`` <-> ``result_files``, ``integrators`` <-> ``plants`` <-> ``plants.pinocchio``, ``kinematic`` <->
    ``simulate``, and ``resolvers.base`` <-> ``resolvers.registry`` once plug-ins came)."""
    assert cycles(import_graph(functions=True)) == set()
