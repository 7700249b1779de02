"""Seed families: several trained policies (one training setup, different seeds) benchmarked as one.

``--family NAME=PATH[,PATH...]``: each PATH is what ``ppo:PATH`` loads; a single directory that is not itself a run
stands for every run directory directly inside it (sorted). Each member runs as ``ppo:PATH`` (its rows carry
``family`` = NAME); the family adds a row per cycle × scenario and one over all (cycle and scenario :data:`OVERALL`)
with the IQM over the seeds of each ratio and its 95 % bootstrap interval (:mod:`hev_thermal_env.stats`). Seeds
without a ratio are left out; the row's note counts them. See docs/metrics.md, *Seed families*.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.stats import iqm, stratified_iqm_ci

MIN_SEEDS = 2
OVERALL = "all"
"""Cycle and scenario of a family's row over every cycle × scenario."""
NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]*$")
RATIOS = ("frontier_ratio", "fixed_price_ratio")
RUN_FILES = ("model.zip", "best_model.zip", "checkpoints")  # what makes a directory a train.py run


@dataclasses.dataclass(frozen=True)
class Family:
    """A family's name and its members' model paths (each run as ``ppo:PATH``)."""

    name: str
    paths: tuple[str, ...]

    @property
    def members(self) -> tuple[str, ...]:
        """The strategy labels of the members."""
        return tuple(f"ppo:{p}" for p in self.paths)


def _is_run(path: Path) -> bool:
    return path.is_file() or any((path / name).exists() for name in RUN_FILES)


def parse_family(text: str, taken: Iterable[str] = ()) -> Family:
    """The family of a ``NAME=PATH[,PATH...]`` option value (``taken``: the strategies' names). Raises ``ValueError``
    (bad form, bad or taken name, repeated path, fewer than :data:`MIN_SEEDS` runs) or ``FileNotFoundError``."""
    name, sep, spec = str(text).partition("=")
    name = name.strip()
    if not sep or not name or not spec.strip():
        raise ValueError(f"--family {text!r}: expected NAME=PATH,PATH,... (or NAME=DIR, a directory of runs)")
    if not NAME_PATTERN.match(name):
        raise ValueError(f"--family {name!r}: a family name starts with a letter and holds letters, digits, "
                         "'_', '.' or '-'")
    if name in set(taken) or name == OVERALL:
        raise ValueError(f"--family {name!r}: the name is taken (a strategy or {OVERALL!r}); choose another")
    paths = [p.strip() for p in spec.split(",") if p.strip()]
    for p in paths:
        if not Path(p).expanduser().exists():
            raise FileNotFoundError(f"--family {name}: {p} not found")
    if len(paths) == 1 and Path(paths[0]).expanduser().is_dir() and not _is_run(Path(paths[0]).expanduser()):
        folder = Path(paths[0])
        paths = [str(d) for d in sorted(folder.iterdir()) if d.is_dir() and _is_run(d.expanduser())]
        if not paths:
            raise ValueError(f"--family {name}: {folder} is neither a train.py run nor a directory of runs "
                             f"(no subdirectory holds {', '.join(RUN_FILES)})")
    repeated = sorted({p for p in paths if paths.count(p) > 1})
    if repeated:
        raise ValueError(f"--family {name}: {repeated[0]} is listed twice")
    if len(paths) < MIN_SEEDS:
        raise ValueError(f"--family {name}: a seed family needs at least {MIN_SEEDS} runs, got {len(paths)} "
                         f"({', '.join(paths)}); benchmark one policy as ppo:{paths[0]}")
    return Family(name, tuple(paths))


def tag_members(rows: list[dict], families: Sequence[Family], strategies: Iterable[str] = ()) -> None:
    """Set ``family`` on every run row: the family's name for its members, None for the others (and for a
    member that is also one of ``strategies``, shown on its own)."""
    alone = set(strategies)
    owner = {label: f.name for f in families for label in f.members if label not in alone}
    for r in rows:
        r.setdefault("family", owner.get(r["strategy"]))


def family_rows(rows: Sequence[dict], families: Sequence[Family]) -> list[dict]:
    """The family rows: one per family and cycle × scenario of ``rows`` (in their order), then one per family
    over every cycle × scenario (``cycle`` = ``scenario`` = :data:`OVERALL`)."""
    out: list[dict] = []
    tasks = list(dict.fromkeys((r["cycle"], r["scenario"]) for r in rows))
    for fam in families:
        per_task = {t: [r for r in rows if (r["cycle"], r["scenario"]) == t and r["strategy"] in fam.members]
                    for t in tasks}
        per_task = {t: m for t, m in per_task.items() if m}
        for (cycle, scenario), members in per_task.items():
            out.append(_summary_row(fam, cycle, scenario, [members], members[0].get("reference")))
        if per_task:
            refs = {m[0].get("reference") for m in per_task.values()}
            ref = refs.pop() if len(refs) == 1 else "per cycle and scenario (see its rows)"
            out.append(_summary_row(fam, OVERALL, OVERALL, list(per_task.values()), ref))
    return out


def _summary_row(fam: Family, cycle: str, scenario: str, groups: list[list[dict]], reference: Any) -> dict:
    """IQM and interval of each ratio over the seeds of ``groups`` (one group of member rows per task)."""
    row: dict[str, Any] = {"cycle": cycle, "scenario": scenario, "strategy": fam.name, "family": fam.name,
                           "seeds": len(fam.paths), "reference": reference}
    members = [m for g in groups for m in g]
    for key in RATIOS:
        centre, low, high = stratified_iqm_ci([[m[key] for m in g if m.get(key) is not None] for g in groups])
        row[key], row[f"{key}_ci_low"], row[f"{key}_ci_high"] = centre, low, high
    for key in ("fuel_corrected_l_per_100km", "cost_g"):
        values = [m[key] for m in members if m.get(key) is not None]
        row[key] = iqm(values) if values else None
    row["charge_sustaining"] = all(bool(m.get("charge_sustaining")) for m in members)
    row["charge_sustaining_runs"] = sum(bool(m.get("charge_sustaining")) for m in members)
    row["runs"] = len(members)
    missing = sum(m.get("frontier_ratio") is None for m in members)
    row["frontier_note"] = (f"{missing} of {len(members)} runs without a frontier ratio (left out)" if missing
                            else None)
    return row


def representative(rows: Sequence[dict], fam: Family, cycle: str, scenario: str) -> str | None:
    """The member (its trace drawn) whose frontier (else fixed-price) ratio is nearest the family's IQM; None if none
    ran on that cycle and scenario."""
    members = [r for r in rows if r["cycle"] == cycle and r["scenario"] == scenario and r["strategy"] in fam.members]
    for key in RATIOS:
        scored = [r for r in members if r.get(key) is not None]
        if scored:
            centre = iqm([r[key] for r in scored])
            return min(scored, key=lambda r: abs(r[key] - centre))["strategy"]
    return members[0]["strategy"] if members else None
