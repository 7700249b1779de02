"""The benchmark (``evaluate.py benchmark``, :func:`run_benchmark`): every strategy on every cycle and scenario,
measured against the thermal optimum (``dp_thermal``, added where missing), into the result files
(:mod:`.results_table`) and figures (:mod:`.plots`). The runs are spread over processes or Ray tasks
(:mod:`.executors`); each is deterministic, so the files equal a serial run's byte for byte. docs/benchmark.md.

Seed families (``--family NAME=PATH[,PATH...]``, :func:`parse_family`): trained policies of one setup benchmarked as
one, each member as ``ppo:PATH``; a row per cycle × scenario and one over all (:data:`OVERALL`) with the IQM over the
seeds of each ratio and its 95 % bootstrap interval (docs/metrics.md, *Seed families*).
"""

from __future__ import annotations

import dataclasses
import os
import re
import threading
import time
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from hev_thermal_env.agents import Strategy, get_strategy, list_strategies, registered, strategy_class
from hev_thermal_env.cycles import ImplausibleCycleWarning, load_cycle
from hev_thermal_env.envs.render import SPLIT_INFO_KEY
from hev_thermal_env.io import check_writable_dir
from hev_thermal_env.physics.config import LATEST_PHYSICS
from hev_thermal_env.scenarios import get_scenario
from hev_thermal_env.stats import iqm, stratified_iqm_ci

from .executors import make_executor
from .plots import plot_benchmark
from .results_table import OVERALL, write_results
from .runner import run_strategy
from .score import REFERENCE, add_yardstick_columns, with_reference

DEFAULT_CYCLES = ("hwfet", "beijing")
DEFAULT_SCENARIOS = ("paper",)
DEFAULT_STRATEGIES = tuple(cls.name for cls in registered() if cls.in_benchmark)
"""The registered strategies marked ``in_benchmark``, in their order."""
REFERENCE_ADDED_NOTE = f"{REFERENCE} was added to the strategies: it is the reference of both ratios."
TRACE_KEYS = ("time_s", "speed_mps", "cycle_speed_mps", "soc", "motor_temp_c", "heat_index", SPLIT_INFO_KEY,
              "motor_torque_nm", "engine_torque_nm", "fuel_g", "missed_wheel_energy_j", "motor_cutoff",
              "shaft_torque_demand_nm")
#: A run in progress counts its elapsed time up to this fraction of its weight.
RUNNING_CREDIT = 0.9
BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]"
#: Seconds between two redraws of the progress bar.
REFRESH_S = 1.0
MIN_SEEDS = 2
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


def _is_run(path: Path) -> bool:  # a train.py run
    return path.is_file() or any((path / name).exists() for name in RUN_FILES)


def parse_family(text: str, taken: Iterable[str] = ()) -> Family:
    """The family of a ``NAME=PATH[,PATH...]`` option value (``taken``: the strategies' names); a single directory
    that is not itself a run stands for every run directory directly inside it (sorted)."""
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
    """Set ``family`` on every run row: its family's name, None for others and members among ``strategies``."""
    alone = set(strategies)
    owner = {label: f.name for f in families for label in f.members if label not in alone}
    for r in rows:
        r.setdefault("family", owner.get(r["strategy"]))


def family_rows(rows: Sequence[dict], families: Sequence[Family]) -> list[dict]:
    """The family rows: per family, one per cycle × scenario of ``rows`` and one over all (:data:`OVERALL`); seeds
    without a ratio are left out, the row's note counts them."""
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
    held = [bool(m.get("charge_sustaining")) for m in members]
    missing = sum(m.get("frontier_ratio") is None for m in members)
    return row | {"charge_sustaining": all(held), "charge_sustaining_runs": sum(held), "runs": len(members),
                  "frontier_note": f"{missing} of {len(members)} runs without a frontier ratio (left out)" if missing
                  else None}


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


def _run_one(task: tuple[str, str, str, dict, int]) -> tuple[dict, dict]:
    """One run's summary row and trace; a run its strategy cannot make (a ``ValueError``, e.g. no plan of the optimum
    ends in its SOC band) is a row holding ``error``, so the other runs still finish."""
    cycle, scenario, strategy, options, physics = task
    with warnings.catch_warnings():  # the main process warned about implausible cycle data when validating
        warnings.simplefilter("ignore", ImplausibleCycleWarning)
        cyc = load_cycle(cycle)
    try:
        res = run_strategy(get_strategy(strategy, **options.get(strategy, {})), cyc, scenario, physics=physics)
    except ValueError as exc:
        return {"cycle": cyc.name, "scenario": scenario, "strategy": strategy, "error": " ".join(str(exc).split())}, {}
    trace = {k: np.asarray(res.trace[k]) for k in TRACE_KEYS if k in res.trace}
    return {**res.summary, "cycle": cyc.name, "scenario": scenario, "strategy": strategy}, trace


def validate(cycles, strategies, scenarios, out: Path, options: dict, families: list[Family]) -> dict[str, Any]:
    """Fail before any work on bad names, strategies or output directory; returns the cycles by the names given."""
    loaded = {c: load_cycle(c) for c in cycles}
    for s in scenarios:
        get_scenario(s)
    names = set(list_strategies()) | set(strategies)
    for f in families:
        if f.name in names:
            raise ValueError(f"--family {f.name!r}: the name is taken (a strategy or another family); choose another")
        names.add(f.name)
    for s in strategies:
        get_strategy(s, **options.get(s, {}))
    for f in families:
        for path, member in zip(f.paths, f.members):
            try:
                get_strategy(member, **options.get(member, {}))
            except (ValueError, OSError) as exc:  # say which member of which family
                kind = ValueError if isinstance(exc, ValueError) else OSError
                raise kind(f"--family {f.name}: {path}: {' '.join(str(exc).split())}") from None
    check_writable_dir(out)
    return loaded


def run_benchmark(out_dir: str | Path, cycles=DEFAULT_CYCLES, strategies=DEFAULT_STRATEGIES,
                  scenarios=DEFAULT_SCENARIOS, *, jobs: int | None = None, options: dict | None = None,
                  progress: bool = True, plots: bool = True, executor: str = "local",
                  address: str | None = None, families: list[Family] | None = None,
                  physics: int = LATEST_PHYSICS) -> list[dict]:
    """Run every combination on physics version ``physics``, write the result files and plots, return the rows (runs,
    then families). ``dp_thermal`` is added to ``strategies`` if missing; ``families``: seed families
    (:func:`parse_family`); ``executor``: ``local`` (``jobs`` processes) or ``ray`` (a local runtime of ``jobs`` CPUs,
    or the cluster at ``address``). Runs that raise ``ValueError`` are left out of the files (their cell's ratios too,
    where it is the reference's), named in ``results.md``, and raised together as one ``ValueError`` after the files
    are written."""
    out = Path(out_dir)
    strategies, added = with_reference(strategies)
    fams = list(families or [])
    options = options or {}
    loaded = validate(cycles, strategies, scenarios, out, options, fams)
    run_names = list(dict.fromkeys([*strategies, *(m for f in fams for m in f.members)]))
    tasks = [(c, sc, st, options, physics) for c in cycles for sc in scenarios for st in run_names]
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(tasks)))
    t0 = time.perf_counter()
    with make_executor(executor, jobs=jobs, address=address) as runner:
        results = _run_tasks(tasks, runner, progress, {c: (cyc.name, cyc.n_steps) for c, cyc in loaded.items()})
    failed = [row for row, _ in results if "error" in row]
    rows = [row for row, _ in results if "error" not in row]
    traces = {(r["cycle"], r["scenario"], r["strategy"]): trace for r, trace in results if "error" not in r}
    add_yardstick_columns(rows)
    tag_members(rows, fams, strategies)
    rows += family_rows(rows, fams)
    notes = ([REFERENCE_ADDED_NOTE] if added else []) + [f"Failed, left out: {_failure(f)}" for f in failed]
    write_results(out, rows, wall_s=time.perf_counter() - t0, notes=notes)
    if plots:
        cycle_names = list(dict.fromkeys(r["cycle"] for r in rows if r.get("family") is None))
        plot_benchmark(out, rows, _plotted_traces(traces, rows, strategies, fams), cycle_names, list(scenarios))
    if failed:
        raise ValueError(f"{len(failed)} of {len(tasks)} runs failed (the other runs are in {out}): "
                         + "; ".join(_failure(f) for f in failed))
    return rows


def _failure(row: dict) -> str:
    return f"{row['cycle']}/{row['scenario']}/{row['strategy']}: {row['error']}"


def _run_tasks(tasks: list[tuple], executor, progress: bool, cycles: dict[str, tuple[str, int]]
               ) -> list[tuple[dict, dict]]:
    """``_run_one`` of every task on ``executor``, in the order of ``tasks``; ``cycles``: (name, steps) of each."""
    costs = [expected_cost_s(st, cycles[c][1]) for c, _, st, *_ in tasks]
    order = sorted(range(len(tasks)), key=lambda i: (-costs[i], i))  # slow runs first: the workers stay busy
    labels = [f"{cycles[c][0]}/{sc}/{st}" for c, sc, st, *_ in tasks]
    results: list[Any] = [None] * len(tasks)
    with BenchmarkProgress(labels, costs, order, executor.slots, enabled=progress) as bar:
        for item in executor.map(_run_one, tasks, order, tick_s=REFRESH_S):
            if item is not None:
                results[item[0]] = item[1]
                bar.finished(item[0])
    return results


def _plotted_traces(traces: dict, rows: list[dict], strategies: list[str], families: list[Family]) -> dict:
    """The traces the figures show: every strategy's run, and per family its member nearest the family's IQM."""
    shown = {k: v for k, v in traces.items() if k[2] in strategies}
    for f in families:
        for cyc, sc in dict.fromkeys((k[0], k[1]) for k in traces):
            pick = representative(rows, f, cyc, sc)
            if pick is not None:
                shown[(cyc, sc, f"{f.name}: seed nearest IQM")] = traces[(cyc, sc, pick)]
    return shown


def expected_cost_s(strategy: str, n_steps: int) -> float:
    """Expected seconds of one run of ``strategy`` over a cycle of ``n_steps`` seconds, without a plan on disk."""
    cls = strategy_class(strategy) or Strategy  # an unregistered name: the defaults of a drive through the cycle
    return cls.overhead_s + cls.seconds_per_step * n_steps


class BenchmarkProgress:
    """A tqdm bar over runs ``labels`` of expected costs ``costs`` (seconds, not runs: runs differ in cost by four
    orders of magnitude), handed out in ``order`` to ``slots`` workers; the time left is tqdm's. A finished run adds
    its weight, a run in progress its elapsed time up to :data:`RUNNING_CREDIT` of its weight (a
    slower run weighs more as it goes); the postfix names the first ``slots`` unfinished runs (first in, first out).
    :meth:`finished` when a run ends; a thread redraws it every :data:`REFRESH_S` seconds within a ``with`` block."""

    def __init__(self, labels: Sequence[str], costs: Sequence[float], order: Sequence[int], slots: int,
                 enabled: bool = True):
        self.labels, self.costs, self.waiting = list(labels), [float(c) for c in costs], list(order)
        self.slots, self.started, self.done_cost = max(1, int(slots)), {}, 0.0
        self.bar = tqdm(total=sum(self.costs), desc="benchmark", disable=not enabled, smoothing=0,
                        bar_format=BAR_FORMAT)
        self.lock, self.closing = threading.Lock(), threading.Event()
        self.refresher = threading.Thread(target=self._refresh, name="benchmark-progress", daemon=True)

    def __enter__(self) -> BenchmarkProgress:
        self.show()
        self.refresher.start()
        return self

    def __exit__(self, *exc) -> None:
        self.closing.set()
        self.refresher.join()
        self.bar.close()

    def _refresh(self) -> None:
        while not self.closing.wait(REFRESH_S):
            self.show()

    def finished(self, i: int) -> None:
        with self.lock:
            self.waiting.remove(i)
            self.started.pop(i, None)
            self.done_cost += self.costs[i]
        self.show()

    def show(self) -> None:
        with self.lock:
            now = time.perf_counter()
            running = self.waiting[:self.slots]
            for i in running:  # a run that takes longer than expected is at most 90 % done
                self.started.setdefault(i, now)
                self.costs[i] = max(self.costs[i], (now - self.started[i]) / RUNNING_CREDIT)
            self.bar.total = sum(self.costs)
            credit = sum(min(now - self.started[i], RUNNING_CREDIT * self.costs[i]) for i in running)
            work = self.done_cost + credit if self.waiting else self.bar.total
            done = len(self.labels) - len(self.waiting)
            names = ", ".join(f"{self.labels[i]} {tqdm.format_interval(now - self.started[i])}" for i in running)
            self.bar.set_postfix_str(f"{done}/{len(self.labels)} runs done" + (f"; running {names}" if names else ""),
                                     refresh=False)
            self.bar.n = max(work, self.bar.n)  # tqdm's rate: work done over time elapsed (smoothing=0)
            self.bar.refresh()
