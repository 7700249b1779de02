"""The size of the library code: lines per room, the largest modules and the longest functions.

Library code is every ``*.py`` under ``hev_thermal_env/`` and ``agents/``, counted as ``wc -l`` counts it
(docstrings and comments included). A function's length is its lines of code without its docstring, as
``tests/test_architecture.py`` counts it.

The room graph (which room imports which, imports inside functions counted) is written into
``docs/architecture.md`` between the ``rooms:begin`` and ``rooms:end`` markers with ``--write-docs``;
``tests/test_architecture.py`` checks that the page's table is the code's.

Usage::

    python benchmarks/code_size.py                # prints the summary, writes benchmarks/results/code_size.json
    python benchmarks/code_size.py --write-docs   # also redraws the room table of docs/architecture.md
"""

from __future__ import annotations

import argparse
import ast
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ("hev_thermal_env", "agents")
OUT = ROOT / "benchmarks" / "results" / "code_size.json"
ARCHITECTURE = ROOT / "docs" / "architecture.md"
BEGIN, END = "<!-- rooms:begin -->", "<!-- rooms:end -->"


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


def room_of(path: Path) -> str:
    """The room of a library file: its folder under the package (``agents`` for the strategies), or the
    module's own name for a top-level module."""
    rel = path.relative_to(ROOT)
    if rel.parts[0] == "agents":
        return "agents"
    return rel.parts[1] if len(rel.parts) > 2 else rel.stem.replace("__init__", "(package)")


def _imported_rooms(path: Path) -> set[str]:
    """The project rooms ``path`` imports, anywhere in the file (inside functions too)."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1]).replace("agents", "hev_thermal_env.agents", 1)
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[:len(package.split(".")) - (node.level - 1)] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            names = [mod] if node.module else [f"{mod}.{a.name}" for a in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "hev_thermal_env" and len(parts) > 1:
                found.add(parts[1])
    return found


def room_graph() -> dict[str, set[str]]:
    """Each room and the other rooms it imports."""
    graph: dict[str, set[str]] = {}
    for path in library_files():
        room = room_of(path)
        graph.setdefault(room, set()).update(r for r in _imported_rooms(path) if r != room)
    return graph


def room_table() -> str:
    """The room graph as a markdown table, rooms ordered from the bottom (imports nothing) up."""
    graph = room_graph()
    floor: dict[str, int] = {}

    def depth(room: str) -> int:
        if room not in floor:
            floor[room] = 0
            floor[room] = 1 + max((depth(r) for r in graph.get(room, ()) if r in graph), default=-1)
        return floor[room]

    rows = sorted(graph, key=lambda r: (depth(r), r))
    out = ["| floor | room | imports |", "|---:|---|---|"]
    out += [f"| {depth(r)} | `{r}` | {', '.join(f'`{d}`' for d in sorted(graph[r])) or '-'} |"
            for r in rows]
    return "\n".join(out)


def write_docs(path: Path = ARCHITECTURE) -> None:
    """Redraw the room table of ``docs/architecture.md`` between its markers."""
    text = path.read_text()
    head, rest = text.split(BEGIN, 1)
    path.write_text(f"{head}{BEGIN}\n{room_table()}\n{END}{rest.split(END, 1)[1]}")


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
    ap.add_argument("--write-docs", action="store_true", help="redraw the room table of docs/architecture.md")
    args = ap.parse_args()
    if args.write_docs:
        write_docs()
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
