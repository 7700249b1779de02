"""Energy-management strategies behind one protocol (:mod:`.base`), installed as ``hev_thermal_env.agents`` (the
source folder is the top-level ``agents/``): ``get_strategy("dp", n_soc=801)``, :func:`list_strategies`.

``get_strategy("name:arg")`` builds the strategy with its class's ``from_label(arg, **options)`` if it has one (``ppo``:
the text after the colon is a model path), else reports the run under the label ``"name:arg"``. Every module of this
folder is imported with the package and registers its strategies (:func:`.base.register`); none imports torch before
``ppo`` is built. Beside them: ``policies/`` (the shipped PPO policy), ``hyperparams/`` (:data:`HYPERPARAMS_DIR`) and
:mod:`.policy_files` (the files of a trained policy).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path
from typing import Any

from .base import Strategy, register, registered, strategy_class

HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
"""The hyperparameter files of ``train.py`` (``<algo>.yaml``)."""

#: Modules of this folder that hold no strategy.
_NOT_STRATEGIES = ("base", "policy_files")
for _module in pkgutil.iter_modules(__path__):
    if _module.name not in _NOT_STRATEGIES and not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")


def list_strategies() -> list[str]:
    """Names accepted by :func:`get_strategy`, in their order (:attr:`.base.Strategy.order`)."""
    return [cls.name for cls in registered()]


def get_strategy(name: str, **options: Any) -> Strategy:
    """A new strategy by name, with its options.

    An unknown name, an unknown option or an option value of the wrong type raises ``ValueError`` naming the strategy
    and listing the valid names or options.
    """
    if not isinstance(name, str):
        raise ValueError(f"strategy name must be a string, got {type(name).__name__}")
    base, _, label = name.partition(":")
    factory = strategy_class(base)
    if factory is None:
        raise ValueError(f"unknown strategy {name!r}; valid strategies: {', '.join(list_strategies())}")
    from_label = getattr(factory, "from_label", None)
    build = from_label if label and from_label is not None else factory
    params = list(inspect.signature(build).parameters.values())[1 if build is from_label else 0:]
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params):  # unknown option names: list the known
        known = [p.name for p in params if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                      inspect.Parameter.KEYWORD_ONLY)]
        unknown = [k for k in options if k not in known]
        if unknown:
            raise ValueError(f"strategy {base!r}: unknown option(s) {unknown}; valid options: "
                             f"{', '.join(known) or 'none'}")
    try:
        strategy = build(label, **options) if build is from_label else build(**options)
    except (TypeError, ValueError) as exc:  # a value of the wrong type or out of range
        if str(exc).startswith(base):  # the strategy's own message names it already
            raise
        raise ValueError(f"strategy {base!r}: bad option value ({exc}); options given: {options}") from None
    if label and build is not from_label:
        strategy.label = name
    return strategy


__all__ = ["HYPERPARAMS_DIR", "Strategy", "get_strategy", "list_strategies", "register", "registered", "strategy_class"]
