"""The look shared by every figure: the pyplot door, the order and colours of the strategies, legends outside.

Strategies go from the simplest to the optimum (by their classes' ``order``; unregistered names before the optima),
then the learned policies (``ppo``, ``ppo:PATH``, seed families passed as ``learned``) in warm colours with thicker
lines. A registered strategy has its class's colour in every figure (:mod:`hev_thermal_env.agents.base`).
"""

from __future__ import annotations

import itertools
import sys
from collections.abc import Collection, Iterable, Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import strategy_class
from hev_thermal_env.io import save_png

from .score import display_name

NON_INTERACTIVE_BACKENDS = ("agg", "pdf", "svg", "ps", "cairo")

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


def is_learned(strategy: str, learned: Collection[str] = ()) -> bool:
    """A learned policy: a learned strategy's name (``ppo``, ``ppo:PATH``), or a name (before any ``:``) in ``learned``
    (seed families)."""
    cls = strategy_class(strategy)
    return (cls is not None and cls.learned) or str(strategy).split(":", 1)[0] in learned


def ordered(strategies: Iterable[str], learned: Collection[str] = ()) -> list[str]:
    """The strategies from the simplest to the optimum, then the learned ones (each group stable: a stable sort)."""

    def rank(name: str) -> tuple[float, ...]:
        cls = strategy_class(name)
        if is_learned(name, learned):
            return (3,)
        return (2 if cls.optimum else 0, cls.order) if cls is not None else (1,)

    return sorted(dict.fromkeys(strategies), key=rank)


def short_label(strategy: str, width: int = 24) -> str:
    """The strategy's name, a long model path shortened from the left (``ppo:…/run/model.zip``); ``dp`` marked
    ``(thermal-blind)`` (:func:`~hev_thermal_env.evaluation.score.display_name`, not counted in ``width``)."""
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
        cls = strategy_class(name)
        if is_learned(name, learned):
            styles[name] = {"color": next(learned_colours), "lw": 1.6, "zorder": 5}
        elif cls is not None and cls.colour is not None and name == cls.name:
            styles[name] = {"color": cls.colour, "lw": 0.9, "zorder": 3}
        else:
            styles[name] = {"color": next(other_colours), "lw": 0.9, "zorder": 3}
        if cls is not None and cls.line_style is not None:
            styles[name]["ls"] = cls.line_style
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
