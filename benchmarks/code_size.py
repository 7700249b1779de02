"""The size of the library code: lines per room, the largest modules and the longest functions.

Library code is every ``*.py`` under ``hev_thermal_env/`` and ``agents/``, counted as ``wc -l`` counts it
(docstrings and comments included). A function's length is its lines of code without its docstring, as
``tests/test_architecture.py`` counts it.

Usage::

    python benchmarks/code_size.py            # prints the summary, writes benchmarks/results/code_size.json
    python benchmarks/code_size.py --out PATH
"""

from __future__ import annotations

import argparse
import ast
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ("hev_thermal_env", "agents")
OUT = ROOT / "benchmarks" / "results" / "code_size.json"


def library_files() -> list[Path]:
    """Every library source file, sorted (symbolic links are not followed)."""
    files = []
    for top in LIBRARY:
        files += [p for p in (ROOT / top).rglob("*.py") if not any(q.is_symlink() for q in p.parents)]
    return sorted(files)


def function_lengths(path: Path) -> list[tuple[str, int]]:
    """``(qualified name, lines of code without the docstring)`` of every function in ``path``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            n = node.end_lineno - node.lineno + 1
            if ast.get_docstring(node) is not None:
                n -= node.body[0].end_lineno - node.body[0].lineno + 1
            out.append((f"{path.relative_to(ROOT)}:{node.name}", n))
    return out


def measure() -> dict:
    files = library_files()
    lines = {str(p.relative_to(ROOT)): p.read_text().count("\n") for p in files}
    rooms: dict[str, int] = {}
    for rel, n in lines.items():
        parts = Path(rel).parts
        room = "/".join(parts[:2]) if len(parts) > 2 else parts[0] + "/ (top level)"
        rooms[room] = rooms.get(room, 0) + n
    functions = sorted((f for p in files for f in function_lengths(p)), key=lambda f: -f[1])
    return {
        "total_lines": sum(lines.values()),
        "files": len(files),
        "rooms": dict(sorted(rooms.items(), key=lambda kv: -kv[1])),
        "largest_modules": dict(sorted(lines.items(), key=lambda kv: -kv[1])[:10]),
        "longest_functions": dict(functions[:10]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=OUT, help="JSON path (default: %(default)s)")
    args = ap.parse_args()
    result = measure()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"library code: {result['total_lines']} lines in {result['files']} files")
    for room, n in result["rooms"].items():
        print(f"  {room:40s} {n:6d}")
    print("largest modules:", ", ".join(f"{k} {v}" for k, v in list(result["largest_modules"].items())[:3]))
    print("longest functions:", ", ".join(f"{k} {v}" for k, v in list(result["longest_functions"].items())[:3]))
    print(f"written: {args.out}")


if __name__ == "__main__":
    main()
