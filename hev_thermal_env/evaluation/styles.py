"""The look shared by every figure: the pyplot door, the order and colours of the strategies, legends outside.

Strategies go from the simplest to the optimum (:data:`STRATEGY_ORDER`, led by ``conventional``, the reference
vehicle; other names before DP), then the learned policies (``ppo``, ``ppo:PATH``, seed families passed as
``learned``) in warm colours with thicker lines. A strategy has the same colour in every figure; ``dp`` is labelled
thermal-blind (:func:`short_label`).
"""

from __future__ import annotations

import itertools
import sys
from collections.abc import Collection, Iterable, Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.io import save_png

from .yardstick import display_name

NON_INTERACTIVE_BACKENDS = ("agg", "pdf", "svg", "ps", "cairo")

#: Classic strategies from the simplest to the optimum (``conventional`` first: another vehicle, the reference row).
STRATEGY_ORDER = ("conventional", "engine_only", "rule", "ecms", "aecms", "ecms_thermal", "dp", "dp_thermal")
#: Strategies whose names start with one of these are learned policies (``ppo``, ``ppo:PATH``).
LEARNED_PREFIXES = ("ppo",)
#: Strategies that are the optimum (the reference of the fuel ratio).
OPTIMUM = ("dp", "dp_thermal")

_CLASSIC_COLOURS = {"conventional": "#393b79", "engine_only": "#8c564b", "rule": "#bcbd22", "ecms": "#1f77b4",
                    "aecms": "#17becf", "ecms_thermal": "#9467bd", "dp": "#000000", "dp_thermal": "#7f7f7f"}
_OTHER_COLOURS = ("#2ca02c", "#98df8a", "#aec7e8", "#c5b0d5", "#c49c94")
_LEARNED_COLOURS = ("#d62728", "#ff7f0e", "#e377c2", "#8b0000", "#ff9896")
LEARNED_BAND_COLOUR = "#fde0dd"
CYCLE_COLOUR = "#bdbdbd"


def pyplot():
    """``matplotlib.pyplot``, drawing off screen (Agg) unless the session imported pyplot already (a notebook, an
    interactive window: its backend is kept) or chose a file backend."""
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules and matplotlib.get_backend().lower() not in NON_INTERACTIVE_BACKENDS:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def base_name(strategy: str) -> str:
    """``"ppo:runs/x"`` → ``"ppo"``."""
    return str(strategy).split(":", 1)[0]


def is_learned(strategy: str, learned: Collection[str] = ()) -> bool:
    """A learned policy: ``ppo``, ``ppo:PATH``, or a name (before any ``:``) in ``learned`` (seed families)."""
    return base_name(strategy) in LEARNED_PREFIXES or base_name(strategy) in learned


def ordered(strategies: Iterable[str], learned: Collection[str] = ()) -> list[str]:
    """The strategies from the simplest to the optimum, then the learned ones (each group stable)."""
    names = list(dict.fromkeys(strategies))

    def rank(name: str) -> tuple[int, int]:
        base = base_name(name)
        if is_learned(name, learned):
            return (3, names.index(name))
        if base in STRATEGY_ORDER:
            return (2 if base in OPTIMUM else 0, STRATEGY_ORDER.index(base) * 1000 + names.index(name))
        return (1, names.index(name))

    return sorted(names, key=rank)


def short_label(strategy: str, width: int = 24) -> str:
    """The strategy's name, a long model path shortened from the left (``ppo:…/run/model.zip``); ``dp`` marked
    ``(thermal-blind)`` (:func:`~hev_thermal_env.evaluation.yardstick.display_name`, not counted in ``width``)."""
    s = str(strategy)
    suffix = display_name(s)[len(s):]
    if len(s) <= width:
        return s + suffix
    if ":" in s:
        head = s[: s.index(":") + 1]
        return head + "…" + s[-max(width - len(head) - 1, 4):] + suffix
    return s[: width - 1] + "…" + suffix


def strategy_styles(strategies: Sequence[str], learned: Collection[str] = ()) -> dict[str, dict[str, Any]]:
    """``{strategy: matplotlib line keywords}``: colour, width and drawing order for each strategy."""
    styles: dict[str, dict[str, Any]] = {}
    learned_colours, other_colours = itertools.cycle(_LEARNED_COLOURS), itertools.cycle(_OTHER_COLOURS)
    for name in strategies:
        base = base_name(name)
        if is_learned(name, learned):
            styles[name] = {"color": next(learned_colours), "lw": 1.6, "zorder": 5}
        elif base in _CLASSIC_COLOURS and name == base:
            styles[name] = {"color": _CLASSIC_COLOURS[base], "lw": 0.9, "zorder": 3}
        else:
            styles[name] = {"color": next(other_colours), "lw": 0.9, "zorder": 3}
        if base in OPTIMUM:
            styles[name]["ls"] = "--" if base == "dp_thermal" else "-"
    return styles


def legend_outside(fig, handles: Sequence[Any], labels: Sequence[str] | None = None, *, ncol: int = 1,
                   title: str | None = None, loc: str = "outside right upper", fontsize: float = 8.5):
    """A figure legend outside every axes (``loc``: an ``"outside ..."`` place; labels by default the handles'); needs
    a constrained layout."""
    labels = [h.get_label() for h in handles] if labels is None else labels
    return fig.legend(handles, labels, loc=loc, ncol=ncol, title=title, fontsize=fontsize, title_fontsize=fontsize,
                      frameon=False)


def figure_title(fig, text: str, fontsize: float = 11.0):
    """The figure's title, left-aligned so that it never runs into a legend on the upper right."""
    return fig.suptitle(text, x=0.01, ha="left", fontsize=fontsize)


def close(fig) -> None:
    pyplot().close(fig)


def save_fig(fig, path) -> Path:
    """Write ``fig`` to the PNG ``path`` atomically (:func:`hev_thermal_env.io.save_png`) and close it."""
    try:
        return save_png(fig, path)
    finally:
        close(fig)
