"""The thermal calibration of the pre-registered protocol (docs/calibration/protocol.md, §4).

Only the parameters with status ``fitted`` in docs/calibration/parameter_ranges.yaml are free, within exactly their
[min, max]; every other parameter keeps the code's value (``tests/test_calibration.py`` checks that it is the
YAML's). The cost is Σ r² over the fitted targets F1-F7 (:data:`~tools.paper.figures.FITTED`), r in
tolerances; the held-out targets H1-H6 are measured after each attempt and never enter a cost.

* **Fit** (:func:`fit_starts`): ``scipy.optimize.least_squares`` (trf) in the unit box θ̃ = (θ − min)/(max − min),
  logarithmic for the two conductances, from the documented start (the YAML's value) and 8 Sobol points (scrambled,
  seed 23); the lowest cost is kept, every start is reported.
* **Identifiability** (:func:`identifiability`, :func:`profiles`): the Jacobian ∂r/∂θ̃ by central differences of
  step 0.02 (one-sided within 0.02 of a bound), its singular values, condition number and right singular vectors,
  local standard errors from (JᵀJ)⁻¹ mapped to physical units, distances from the bounds (flagged below 0.05); a
  profile of each parameter over its whole range (21 points, the others re-optimised from the neighbouring point).
* **Fallback** (:func:`calibrate`): a smallest singular value below 0.05 × the largest fixes the parameter that
  dominates its right singular vector, a profile rising by less than 1 over its whole range fixes that parameter,
  at its documented start; the others are fitted again, and every attempt is reported (:mod:`.log`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy import optimize
from scipy.stats import qmc

from hev_thermal_env.physics import VehicleConfig, paper_bus
from tools.paper.figures import FITTED, HELD_OUT, PaperFigure
from tools.paper.measure import Baseline, measure

from . import protocol as proto
from .protocol import FitParam

#: Residual of a fitted target that cannot be measured (not expected within the bounds; keeps the cost finite).
UNMEASURED_RESIDUAL = 100.0


@dataclasses.dataclass(frozen=True)
class Settings:
    """Optimiser and identifiability settings (the protocol's where it fixes them)."""

    n_sobol: int = 8
    seed: int = 23
    max_nfev: int = 100
    ftol: float = 1e-6
    xtol: float = 1e-6
    gtol: float = 1e-8
    diff_step: float = 1e-2
    jac_step: float = 0.02
    profile_points: int = 21
    profile_max_nfev: int = 30
    fallback_ratio: float = 0.05
    profile_rise: float = 1.0
    bound_flag: float = 0.05


class Problem:
    """The residuals r(θ̃) of ``targets`` for the free ``params`` (unit coordinates), the ``fixed`` YAML parameters
    held at their values, everything else at ``base`` (default ``paper_bus()``); counts the model evaluations."""

    def __init__(self, params: Sequence[FitParam], fixed: dict[str, float] | None = None,
                 base: VehicleConfig | None = None, baseline: Baseline | None = None,
                 targets: Sequence[PaperFigure] = FITTED):
        self.params, self.fixed, self.targets = tuple(params), dict(fixed or {}), tuple(targets)
        self.base = base or paper_bus()
        self.baseline = baseline or Baseline(self.base)
        self.evaluations = 0
        self._cache: dict[tuple[float, ...], np.ndarray] = {}

    def values(self, x: Sequence[float]) -> dict[str, float]:
        return {**self.fixed, **{p.name: p.from_unit(u) for p, u in zip(self.params, x)}}

    def config(self, x: Sequence[float]) -> VehicleConfig:
        return proto.with_values(self.base, self.values(x))

    def measure(self, x: Sequence[float], targets: Sequence[PaperFigure]) -> dict[str, float]:
        return measure(self.config(x), self.baseline, targets)["values"]

    def residuals(self, x: Sequence[float]) -> np.ndarray:
        key = tuple(float(v) for v in x)
        if key not in self._cache:
            self.evaluations += 1
            values = self.measure(key, self.targets)
            r = np.array([t.residual(values[t.name]) for t in self.targets])
            self._cache[key] = np.where(np.isfinite(r), r, UNMEASURED_RESIDUAL)
        return self._cache[key]

    def cost(self, x: Sequence[float]) -> float:
        return float(np.sum(self.residuals(x) ** 2))


@dataclasses.dataclass
class Start:
    label: str
    x0: list[float]
    x: list[float]
    values: dict[str, float]
    cost: float
    evaluations: int
    status: int
    message: str


def start_points(params: Sequence[FitParam], settings: Settings) -> list[tuple[str, np.ndarray]]:
    """The documented start (the YAML's values) and ``n_sobol`` scrambled Sobol points (seed ``seed``)."""
    out = [("documented", np.array([p.to_unit(p.start) for p in params]))]
    if params and settings.n_sobol:
        sobol = qmc.Sobol(d=len(params), scramble=True, seed=settings.seed).random(settings.n_sobol)
        out += [(f"sobol {i + 1}", s) for i, s in enumerate(sobol)]
    return out


def _least_squares(fun: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, settings: Settings,
                   max_nfev: int) -> optimize.OptimizeResult:
    return optimize.least_squares(fun, x0, bounds=(0.0, 1.0), method="trf", jac="2-point",
                                  diff_step=settings.diff_step, ftol=settings.ftol, xtol=settings.xtol,
                                  gtol=settings.gtol, max_nfev=max_nfev)


def fit_from(problem: Problem, label: str, x0: Sequence[float], settings: Settings) -> Start:
    """One least-squares fit from the unit coordinates ``x0``."""
    before = problem.evaluations
    x0 = np.asarray(x0, dtype=float)
    if problem.params:
        res = _least_squares(problem.residuals, x0, settings, settings.max_nfev)
        x, status, message = np.clip(res.x, 0.0, 1.0), int(res.status), str(res.message)
    else:
        x, status, message = x0, 0, "nothing to fit"
    return Start(label, [float(v) for v in x0], [float(v) for v in x], problem.values(x), problem.cost(x),
                 problem.evaluations - before, status, message)


def fit_starts(problem: Problem, settings: Settings, tick: Callable[[str, float], None]) -> list[Start]:
    """One least-squares fit from each of :func:`start_points`."""
    starts = []
    for label, x0 in start_points(problem.params, settings):
        starts.append(fit_from(problem, label, x0, settings))
        tick(label, starts[-1].cost)
    return starts


def jacobian(problem: Problem, x: np.ndarray, step: float) -> tuple[np.ndarray, list[str]]:
    """∂r/∂θ̃ by central differences of ``step``; one-sided where a central point would leave the unit box."""
    cols, kinds = [], []
    for j in range(len(x)):
        lo, hi = x.copy(), x.copy()
        lo[j], hi[j] = x[j] - step, x[j] + step
        kind = "central"
        if lo[j] < 0.0:
            lo[j], kind = x[j], "forward"
        if hi[j] > 1.0:
            hi[j], kind = x[j], "backward"
        cols.append((problem.residuals(hi) - problem.residuals(lo)) / (hi[j] - lo[j]))
        kinds.append(kind)
    return np.column_stack(cols) if cols else np.zeros((len(problem.targets), 0)), kinds


def identifiability(problem: Problem, x: np.ndarray, settings: Settings) -> dict[str, Any]:
    """The Jacobian's singular values, condition number, right singular vectors (rows of ``vt``), local standard
    errors (unit and physical), distances from the bounds and their flags (module docstring)."""
    jac, kinds = jacobian(problem, x, settings.jac_step)
    if jac.shape[1] == 0:
        return {"jacobian": [], "steps": [], "singular_values": [], "condition_number": float("nan"), "vt": [],
                "se_unit": [], "se_physical": [], "distance_from_bounds": [], "near_bound": []}
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    jtj = jac.T @ jac
    se = (np.sqrt(np.clip(np.diag(np.linalg.inv(jtj)), 0.0, None)) if sv[-1] > 1e-12 * max(sv[0], 1e-300)
          else np.full(len(x), np.inf))
    values = [p.from_unit(u) for p, u in zip(problem.params, x)]
    dist = [min(u, 1.0 - u) for u in x]
    return {"jacobian": jac.tolist(), "steps": kinds, "singular_values": sv.tolist(),
            "condition_number": float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf"), "vt": vt.tolist(),
            "se_unit": se.tolist(),
            "se_physical": [float(s * p.d_value_d_unit(v)) for s, p, v in zip(se, problem.params, values)],
            "distance_from_bounds": dist, "near_bound": [d < settings.bound_flag for d in dist]}


def _profile_one(problem: Problem, x_best: np.ndarray, j: int, settings: Settings,
                 tick: Callable[[str, float], None]) -> dict[str, Any]:
    """Σr² with θ̃_j on a grid over [0, 1], the others re-optimised, walking out from the optimum both ways; Δ is
    measured from the fit's Σr² (``below_fit`` < 0: the profile found a lower cost, the fit is a local minimum)."""
    grid = np.linspace(0.0, 1.0, settings.profile_points)
    others = [k for k in range(len(x_best)) if k != j]
    costs = np.full(len(grid), np.nan)
    centre = int(np.argmin(np.abs(grid - x_best[j])))
    for order in (range(centre, len(grid)), range(centre - 1, -1, -1)):
        sub = x_best[others].copy()
        for i in order:
            def full(z: np.ndarray, g: float = grid[i]) -> np.ndarray:
                x = x_best.copy()
                x[j], x[others] = g, z
                return x
            if others:
                res = _least_squares(lambda z: problem.residuals(full(z)), sub, settings, settings.profile_max_nfev)
                sub = np.clip(res.x, 0.0, 1.0)
            costs[i] = problem.cost(full(sub))
            tick(f"profile {problem.params[j].name}", costs[i])
    delta = costs - problem.cost(x_best)
    left, right = grid < x_best[j], grid > x_best[j]
    p = problem.params[j]
    return {"name": p.name, "grid_unit": grid.tolist(), "grid_values": [p.from_unit(g) for g in grid],
            "cost": costs.tolist(), "delta": delta.tolist(),
            "identified_low": bool(left.any() and delta[left].max() >= settings.profile_rise),
            "identified_high": bool(right.any() and delta[right].max() >= settings.profile_rise),
            "flat": bool(delta.max() < settings.profile_rise), "below_fit": float(min(delta.min(), 0.0)),
            "argmin_value": p.from_unit(grid[int(np.argmin(costs))])}


def profiles(problem: Problem, x_best: np.ndarray, settings: Settings,
             tick: Callable[[str, float], None]) -> list[dict[str, Any]]:
    return [_profile_one(problem, x_best, j, settings, tick) for j in range(len(x_best))]


def fallback_fixes(params: Sequence[FitParam], ident: dict[str, Any], profs: list[dict[str, Any]],
                   settings: Settings) -> dict[str, str]:
    """The parameters the protocol's fallback fixes, with the reason for each."""
    fixes: dict[str, str] = {}
    sv = ident["singular_values"]
    if sv and sv[-1] < settings.fallback_ratio * sv[0]:
        weakest = np.abs(np.asarray(ident["vt"])[-1])
        fixes[params[int(np.argmax(weakest))].name] = (
            f"smallest singular value {sv[-1]:.3g} < {settings.fallback_ratio:g} × largest {sv[0]:.3g}; "
            "largest component of its right singular vector")
    for prof in profs:
        if prof["flat"]:
            rise = max(prof["delta"])
            fixes.setdefault(prof["name"], f"profile flat: rises by {rise:.3g} < {settings.profile_rise:g} "
                                           "over the whole range")
    return fixes


@dataclasses.dataclass
class Attempt:
    """One fit of the protocol: free and fixed parameters, every start, the best, its identifiability and
    profiles, its fitted and held-out values, wall time, adopted or not and why."""

    label: str
    free: list[str]
    fixed: dict[str, float]
    settings: dict[str, Any]
    starts: list[Start]
    best: int
    values: dict[str, float]
    x: list[float]
    cost: float
    identifiability: dict[str, Any]
    profiles: list[dict[str, Any]]
    measured: dict[str, float]
    residuals: dict[str, float]
    evaluations: int
    wall_s: float
    fallback: dict[str, str]
    adopted: bool = False
    note: str = ""


def run_attempt(label: str, params: Sequence[FitParam], fixed: dict[str, float], settings: Settings,
                baseline: Baseline, *, with_profiles: bool = True, bar: Any = None) -> Attempt:
    """Fit ``params`` (``fixed`` held) from every start, then the identifiability of the best fit."""
    t0 = time.perf_counter()
    problem = Problem(params, fixed, baseline=baseline)

    def tick(what: str, cost: float) -> None:
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"{label}: {what}, Σr² {cost:.3f}, {problem.evaluations} runs")

    starts = fit_starts(problem, settings, tick)
    best = int(np.argmin([s.cost for s in starts]))
    x = np.array(starts[best].x)
    ident = identifiability(problem, x, settings)
    profs = profiles(problem, x, settings, tick) if with_profiles else []
    values = problem.values(x)
    measured = problem.measure(x, FITTED + HELD_OUT)
    residuals = {t.name: t.residual(measured[t.name]) for t in FITTED + HELD_OUT}
    return Attempt(label, [p.name for p in params], dict(fixed), dataclasses.asdict(settings), starts, best, values,
                   x.tolist(), starts[best].cost, ident, profs, measured, residuals, problem.evaluations,
                   time.perf_counter() - t0, fallback_fixes(params, ident, profs, settings))


def calibrate(settings: Settings = Settings(), *, with_profiles: bool = True, progress: bool = True,
              base: VehicleConfig | None = None) -> list[Attempt]:
    """The protocol's fit and, while its fallback rule fixes a parameter, the fits with the rest; the last attempt
    is adopted. Profiles are needed for the fallback's second rule (``with_profiles=False`` skips them)."""
    from tqdm.auto import tqdm

    params = list(proto.fitted_parameters())
    baseline = Baseline(base or paper_bus())
    fixed: dict[str, float] = {}
    attempts: list[Attempt] = []
    while True:
        n_steps = (settings.n_sobol + 1) + (len(params) * settings.profile_points if with_profiles else 0)
        label = "all fitted" if not fixed else "fallback: " + ", ".join(f"{k} fixed" for k in fixed)
        with tqdm(total=n_steps, desc=f"fit ({len(params)} free)", disable=not progress, leave=False) as bar:
            attempt = run_attempt(label, params, fixed, settings, baseline, with_profiles=with_profiles, bar=bar)
        attempts.append(attempt)
        if not attempt.fallback or not params:
            break
        for p in [p for p in params if p.name in attempt.fallback]:
            fixed[p.name] = p.start
        params = [p for p in params if p.name not in attempt.fallback]
    for a in attempts[:-1]:
        a.note = "not adopted: the fallback rule fixed " + "; ".join(f"{k} ({v})" for k, v in a.fallback.items())
    attempts[-1].adopted = True
    attempts[-1].note = "adopted"
    return attempts


def round_sig(x: float, digits: int = 5) -> float:
    """``x`` to ``digits`` significant digits: the precision written into the code's defaults."""
    if x == 0.0 or not math.isfinite(x):
        return float(x)
    return float(round(x, digits - 1 - int(math.floor(math.log10(abs(x))))))
