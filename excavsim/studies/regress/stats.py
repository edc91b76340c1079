"""The statistics of the regression suite: per-seed samples, and one-sided tests of a worsening.

A golden scenario runs over several seeds, so each metric is a sample of per-seed values, not one
number. Whether "now" is worse than a reference (the committed baseline, or another checkout) is
decided by :func:`judge`, in the metric's worse direction, beyond a practical tolerance ``tol``:

* **unpaired** (the baseline mode: another run, possibly on another machine, possibly other
  seeds): the one-sided Mann-Whitney U test of "now, moved by ``tol`` towards better, is still
  stochastically worse than the reference" (:func:`scipy.stats.mannwhitneyu`), and a percentile
  bootstrap interval of the difference of the means (each sample resampled on its own);
* **paired** (the A/B mode: the same seeds on the same machine): the one-sided Wilcoxon
  signed-rank test of "the per-seed differences, less ``tol``, lean worse"
  (:func:`scipy.stats.wilcoxon`, zero differences dropped), and a percentile bootstrap interval of
  the mean per-seed difference.

The verdict is ``regression`` when the test's p-value is below :data:`ALPHA` *and* the whole
:data:`CONFIDENCE` interval lies beyond the tolerance on the worse side, ``improved`` when the
mirror image holds on the better side, ``same`` when both samples are identical, and ``ok``
otherwise (a difference that is not significant, or not larger than the tolerance). Bootstraps use
a fixed seed, so the same numbers always give the same interval. With few seeds a test cannot
reach ``ALPHA`` at all (:func:`smallest_p`): the unpaired test needs 4 seeds a side, the paired
one 5.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence

import numpy as np
from scipy import stats

ALPHA = 0.05
CONFIDENCE = 0.95
N_BOOTSTRAP = 4000
QUANTILES = {"q10": 0.10, "q25": 0.25, "median": 0.50, "q75": 0.75, "q90": 0.90}


def summarize(values: Sequence[float]) -> dict:
    """A sample's statistics as a JSON-ready dict: ``n``, ``mean``, ``std`` (ddof 1; 0 for one
    value), ``min``, the :data:`QUANTILES`, ``max`` and the ``values`` themselves."""
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        raise ValueError("summarize needs at least one value")
    out = {"n": int(x.size), "mean": float(x.mean()), "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
           "min": float(x.min())}
    out.update({k: float(np.quantile(x, q)) for k, q in QUANTILES.items()})
    out.update(max=float(x.max()), values=[float(v) for v in x])
    return out


@dataclasses.dataclass(frozen=True)
class Judgement:
    """The comparison of one metric's samples.

    ``difference`` is mean(now) - mean(reference) in the metric's units (for paired samples the mean
    per-seed difference, the same number), ``interval`` its bootstrap interval, ``p_value`` the
    one-sided p-value of a worsening beyond ``tolerance`` and ``p_improved`` that of an improvement
    beyond it.
    """

    difference: float
    interval: tuple[float, float]
    p_value: float
    p_improved: float
    tolerance: float
    paired: bool
    verdict: str  # "regression", "improved", "ok", "same"


def _p(result) -> float:
    p = float(result.pvalue)
    return 1.0 if math.isnan(p) else p


def _unpaired_p(worse_now: np.ndarray, worse_ref: np.ndarray, alternative: str) -> float:
    if np.all(np.concatenate([worse_now, worse_ref]) == worse_ref[0]):
        return 1.0  # one value everywhere: no evidence either way (scipy would warn)
    return _p(stats.mannwhitneyu(worse_now, worse_ref, alternative=alternative))


def _paired_p(diff: np.ndarray, alternative: str) -> float:
    if np.all(diff == 0):
        return 1.0
    with warnings.catch_warnings():  # very few non-zero differences: scipy warns, the p-value stays valid
        warnings.simplefilter("ignore")
        return _p(stats.wilcoxon(diff, alternative=alternative, zero_method="wilcox"))


def bootstrap_interval(reference: np.ndarray, now: np.ndarray, *, paired: bool, n_boot: int = N_BOOTSTRAP,
                       confidence: float = CONFIDENCE, seed: int = 0) -> tuple[float, float]:
    """The percentile bootstrap interval of mean(now) - mean(reference): paired samples resample the
    per-seed differences, unpaired ones each sample independently. Deterministic (fixed ``seed``)."""
    rng = np.random.default_rng(seed)
    if paired:
        d = now - reference
        boot = d[rng.integers(0, d.size, (n_boot, d.size))].mean(axis=1)
    else:
        boot = (now[rng.integers(0, now.size, (n_boot, now.size))].mean(axis=1)
                - reference[rng.integers(0, reference.size, (n_boot, reference.size))].mean(axis=1))
    lo, hi = np.quantile(boot, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(lo), float(hi)


def judge(reference: Sequence[float], now: Sequence[float], *, higher_is_better: bool, tolerance: float,
          paired: bool, alpha: float = ALPHA) -> Judgement:
    """Whether ``now`` is significantly worse (or better) than ``reference`` beyond ``tolerance``.

    Args:
        reference, now: per-seed values; with ``paired`` the same seeds in the same order.
        higher_is_better: the metric's better direction.
        tolerance: the practical tolerance in the metric's units (>= 0).
        paired: Wilcoxon signed-rank on per-seed differences instead of Mann-Whitney U.

    Raises:
        ValueError: an empty sample, or paired samples of different lengths.
    """
    ref, cur = np.asarray(reference, dtype=float), np.asarray(now, dtype=float)
    if ref.size == 0 or cur.size == 0:
        raise ValueError("judge needs at least one value on each side")
    if paired and ref.size != cur.size:
        raise ValueError(f"paired samples differ in length: {ref.size} and {cur.size}")
    sign = -1.0 if higher_is_better else 1.0  # sign * value grows as the metric gets worse
    difference = float(cur.mean() - ref.mean())
    interval = bootstrap_interval(ref, cur, paired=paired)
    if paired:
        same = bool(np.array_equal(ref, cur))
        d = sign * (cur - ref)
        p_worse, p_better = _paired_p(d - tolerance, "greater"), _paired_p(d + tolerance, "less")
    else:
        same = bool(np.array_equal(np.sort(ref), np.sort(cur)))
        p_worse = _unpaired_p(sign * cur - tolerance, sign * ref, "greater")
        p_better = _unpaired_p(sign * cur + tolerance, sign * ref, "less")
    worse_lo, worse_hi = sorted(sign * v for v in interval)
    if same:
        verdict = "same"
    elif p_worse < alpha and worse_lo > tolerance:
        verdict = "regression"
    elif p_better < alpha and worse_hi < -tolerance:
        verdict = "improved"
    else:
        verdict = "ok"
    return Judgement(difference, interval, p_worse, p_better, tolerance, paired, verdict)


def smallest_p(n_reference: int, n_now: int, *, paired: bool) -> float:
    """The smallest one-sided p-value the test can give with these sample sizes (no ties): below
    :data:`ALPHA` only with enough seeds."""
    if paired:
        return 0.5 ** min(n_reference, n_now)
    return 1.0 / math.comb(n_reference + n_now, n_now)
