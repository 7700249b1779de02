"""Statistics over training seeds: the interquartile mean (IQM, robust to one bad seed, less noisy than the median)
and its 95 % percentile bootstrap interval (``scipy.stats.bootstrap``, 2,000 resamples, a fixed seed), as Agarwal et
al., *Deep RL at the edge of the statistical precipice* (NeurIPS 2021) recommend; over several tasks, a stratified
bootstrap (:func:`stratified_iqm_ci`). See docs/metrics.md, *Seed families*.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 2000
TRIM = 0.25  # cut from each side: the IQM is the mean of the middle 50 %


def iqm(values) -> float:
    """Interquartile mean: the mean of the middle 50 % (``scipy.stats.trim_mean`` cutting 25 % each side)."""
    return float(stats.trim_mean(np.asarray(values, dtype=float).ravel(), TRIM))


def iqm_ci(values) -> tuple[float | None, float | None]:
    """The :data:`CONFIDENCE` bootstrap interval of the IQM of ``values``, one task's scores (:func:`stratified_iqm_ci`
    of one group); (None, None) for fewer than two."""
    return stratified_iqm_ci([values])[1:]


def stratified_iqm_ci(groups: Sequence[Sequence[float]]) -> tuple[float | None, float | None, float | None]:
    """(IQM, CI low, CI high) of the pooled scores of ``groups`` (one group per task, the seeds' scores). The bootstrap
    resamples each group on its own (with replacement, its own size) and takes the IQM of the pooled resample; a
    group of one score enters every resample as it is. Non-finite scores are dropped. (None, None, None) without
    scores; the interval is None with fewer than two."""
    clean = [x[np.isfinite(x)] for x in (np.asarray(g, dtype=float).ravel() for g in groups)]
    clean = [x for x in clean if x.size]
    if not clean:
        return None, None, None
    pooled = np.concatenate(clean)
    centre = iqm(pooled)
    if pooled.size < 2:
        return centre, None, None
    varying = tuple(x for x in clean if x.size > 1)
    fixed = np.concatenate([x for x in clean if x.size == 1] or [np.empty(0)])
    if not varying or np.all(pooled == pooled[0]):  # all equal, or one score per task: nothing to resample
        return centre, centre, centre

    def statistic(*samples, axis):
        batch = np.broadcast_shapes(*(s.shape[:-1] for s in samples))
        parts = [np.broadcast_to(s, batch + s.shape[-1:]) for s in samples]
        parts.append(np.broadcast_to(fixed, batch + fixed.shape))
        return stats.trim_mean(np.concatenate(parts, axis=-1), TRIM, axis=-1)

    res = stats.bootstrap(varying, statistic, confidence_level=CONFIDENCE, n_resamples=BOOTSTRAP_RESAMPLES,
                          method="percentile", rng=np.random.default_rng(0), axis=-1)
    return centre, float(res.confidence_interval.low), float(res.confidence_interval.high)
