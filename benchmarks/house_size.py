"""The size of the library: the measures of the house's targets (BENCHMARKS.md, "The house").

* lines: every line of ``torqueopt/**/*.py`` (``find torqueopt -name '*.py' | xargs cat | wc -l``), files;
* code lines: lines that are neither blank, nor a comment, nor part of a docstring;
* the functions longer than :data:`LONGEST` code lines, by name and length.

    python benchmarks/house_size.py            # the table
    python benchmarks/house_size.py --files    # and each file's lines, largest first
"""

from __future__ import annotations

import argparse
import ast
import io
import tokenize
from pathlib import Path

#: The longest function the house allows [code lines].
LONGEST = 80
ROOT = Path(__file__).resolve().parents[1] / "torqueopt"


def docstring_lines(tree: ast.AST) -> set[int]:
    """The line numbers of every module, class and function docstring in ``tree``."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.body[0] if node.body else None
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
            ):
                lines.update(range(first.lineno, first.end_lineno + 1))
    return lines


def code_lines(source: str, tree: ast.AST) -> set[int]:
    """The line numbers that carry code: a token other than a comment, outside every docstring."""
    skip = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER}
    lines: set[int] = set()
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type not in skip:
            lines.update(range(token.start[0], token.end[0] + 1))
    return lines - docstring_lines(tree)


def measure(root: Path = ROOT) -> dict:
    """Lines, code lines, files and the long functions of the package under ``root``."""
    files, total, code, long = {}, 0, 0, []
    for path in sorted(root.rglob("*.py")):
        source = path.read_text()
        tree = ast.parse(source)
        lines = code_lines(source, tree)
        files[str(path.relative_to(root.parent))] = source.count("\n")
        total += source.count("\n")
        code += len(lines)
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = len([n for n in lines if node.lineno <= n <= node.end_lineno])
                if length > LONGEST:
                    long.append((length, f"{path.relative_to(root.parent)}:{node.lineno} {node.name}"))
    return {"lines": total, "code_lines": code, "files": len(files), "long": sorted(long, reverse=True),
            "per_file": files}  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--files", action="store_true", help="also each file's lines, largest first")
    arguments = parser.parse_args(argv)
    size = measure()
    print(f"lines {size['lines']:,}  code lines {size['code_lines']:,}  files {size['files']}")
    print(f"functions over {LONGEST} code lines: {len(size['long'])}")
    for length, name in size["long"]:
        print(f"  {length:4d}  {name}")
    if arguments.files:
        for name, lines in sorted(size["per_file"].items(), key=lambda item: -item[1]):
            print(f"{lines:6d}  {name}")


if __name__ == "__main__":
    main()
