"""``hev_thermal_env.agents`` when the package runs from a source checkout that is not installed.

The strategies live in the checkout's top-level ``agents/`` folder; installing the project (wheel or
editable) maps that folder to ``hev_thermal_env.agents`` (``package-dir`` in ``pyproject.toml``), so
no top-level ``agents`` module is ever installed. A checkout used without installing it
(``PYTHONPATH=.``, or an editable install made before the mapping existed) has no such mapping: the
finder below supplies it. It is consulted after every other finder, so an installed mapping always
wins, and it only answers for ``hev_thermal_env.agents``.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from importlib.machinery import ModuleSpec
from pathlib import Path

PACKAGE = "hev_thermal_env.agents"
CHECKOUT_ROOT = Path(__file__).resolve().parent.parent
AGENTS_DIR = CHECKOUT_ROOT / "agents"


class CheckoutAgentsFinder(importlib.abc.MetaPathFinder):
    """Finds ``hev_thermal_env.agents`` in the checkout's ``agents/`` folder."""

    def find_spec(self, fullname: str, path=None, target=None) -> ModuleSpec | None:
        if fullname != PACKAGE:
            return None
        return importlib.util.spec_from_file_location(fullname, AGENTS_DIR / "__init__.py",
                                                      submodule_search_locations=[str(AGENTS_DIR)])


def is_checkout() -> bool:
    """True when this package sits in a source checkout (``pyproject.toml`` and ``agents/`` beside it)."""
    return (CHECKOUT_ROOT / "pyproject.toml").is_file() and (AGENTS_DIR / "__init__.py").is_file()


def install() -> None:
    """Append the finder to ``sys.meta_path`` (once) when running from a checkout."""
    if is_checkout() and not any(isinstance(f, CheckoutAgentsFinder) for f in sys.meta_path):
        sys.meta_path.append(CheckoutAgentsFinder())
