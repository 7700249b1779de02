"""Griffe extension of the documentation build (``mkdocs.yml``): the project as it is installed.

* ``hev_thermal_env.agents``: the strategies live in the checkout's top-level ``agents/`` folder
  and are installed under that name (``package-dir`` in ``pyproject.toml``); griffe reads folders,
  so this extension attaches ``agents/`` to the loaded ``hev_thermal_env`` package.
* Sphinx roles in docstrings (``:func:`name```, ``:mod:`.relative```, ``:class:`~a.b.C```) become
  optional cross-references: a link where the target is documented, inline code otherwise, so a
  docstring never breaks the strict build.
* Doctest blocks outside a numpy ``Examples`` section become fenced ``pycon`` code, and a reST
  literal-block marker (``text::``) a plain colon, so they render as code, not as quotes or links.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import griffe

ROOT = Path(__file__).resolve().parents[2]
AGENTS_DIR = ROOT / "agents"

_ROLE = re.compile(r":(?:py:)?(?:mod|func|class|meth|attr|data|exc|obj|const):`(?P<body>[^`]+)`")
_TITLED = re.compile(r"^(?P<title>.+?)\s*<(?P<target>[^<>]+)>$")


class ProjectDocs(griffe.Extension):
    """Attach ``agents/`` as ``hev_thermal_env.agents``; turn Sphinx roles into optional cross-references."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        if pkg.name == "hev_thermal_env" and "agents" not in pkg.members and (AGENTS_DIR / "__init__.py").is_file():
            attach_agents(pkg, loader)
        for obj in walk(pkg):
            if obj.docstring is not None:
                text = fence_doctests(obj.docstring.value)
                obj.docstring.value = _ROLE.sub(lambda m, o=obj: crossref(m["body"], o, loader), text)


def attach_agents(pkg: griffe.Module, loader: griffe.GriffeLoader) -> None:
    """Visit ``agents/*.py`` as the package ``hev_thermal_env.agents``."""
    agents = _visit("agents", AGENTS_DIR / "__init__.py", pkg, loader)
    pkg.set_member("agents", agents)
    for path in sorted(AGENTS_DIR.glob("*.py")):
        if path.name != "__init__.py":
            agents.set_member(path.stem, _visit(path.stem, path, agents, loader))


def _visit(name: str, path: Path, parent: griffe.Module, loader: griffe.GriffeLoader) -> griffe.Module:
    code = path.read_text(encoding="utf-8")
    loader.lines_collection[path] = code.splitlines()
    return griffe.visit(name, path, code, parent=parent, extensions=loader.extensions,
                        lines_collection=loader.lines_collection, modules_collection=loader.modules_collection)


def fence_doctests(text: str) -> str:
    """``>>>`` blocks (up to the next blank line) fenced as ``pycon`` unless in an ``Examples`` section or
    already code; a trailing ``::`` becomes ``:``."""
    lines = text.splitlines()
    out: list[str] = []
    in_fence = in_examples = in_doctest = False
    for i, line in enumerate(lines):
        stripped = line.strip()
        underline = i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}
        if underline and not in_fence:
            in_examples = stripped == "Examples"
        if stripped.startswith("```"):
            in_fence = not in_fence
        indent = len(line) - len(line.lstrip())
        if in_doctest and not stripped:
            out.append("```")
            in_doctest = False
        elif (not in_doctest and not in_fence and not in_examples and stripped.startswith(">>>")
              and indent < 4):
            out.append(" " * indent + "```pycon")
            in_doctest = True
        if not in_fence and not in_doctest and stripped.endswith("::"):
            line = line.rstrip()[:-1] if stripped != "::" else ""
        out.append(line)
    if in_doctest:
        out.append("```")
    return "\n".join(out)


def walk(obj: griffe.Object):
    """The object and every member below it (aliases excluded)."""
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from walk(member)


def crossref(body: str, obj: griffe.Object, loader: griffe.GriffeLoader) -> str:
    """An autorefs tag that links ``body``'s target when it is documented and shows code otherwise."""
    titled = _TITLED.match(body.strip())
    target = (titled["target"] if titled else body).strip()
    short = target.startswith("~")
    target = target.lstrip("~")
    title = titled["title"] if titled else (target.rsplit(".", 1)[-1] if short else target)
    identifier = resolve(target, obj, loader)
    return f'<autoref identifier="{identifier}" optional><code>{title}</code></autoref>'


def resolve(target: str, obj: griffe.Object, loader: griffe.GriffeLoader) -> str:
    """The full path of ``target`` seen from ``obj``: relative to its package (leading dots), else searched
    from ``obj``'s scope upwards; ``target`` itself when nothing is found."""
    scope = obj if obj.is_module else obj.parent
    name = target.lstrip(".")
    candidates = []
    if target.startswith("."):
        module = obj if obj.is_module else obj.module
        base = module.path.split(".") if module.is_package else module.path.split(".")[:-1]
        up = len(target) - len(name) - 1
        candidates.append(".".join([*base[:len(base) - up], name]))
    parts = scope.path.split(".")
    candidates += [".".join([*parts[:n], name]) for n in range(len(parts), 0, -1)]
    return next((c for c in candidates if _exists(c, loader)), name)


def _exists(path: str, loader: griffe.GriffeLoader) -> bool:
    try:
        loader.modules_collection.get_member(path)
    except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return False
    return True
