"""Drift within a process and Tukey outliers (labelled, never dropped)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _GROUP, _check_confidence, _require_columns, _scipy_stats, _t_interval, _timed, _vector
from .defaults import DEFAULTS


@dataclass(frozen=True)
class Drift:
    """Trends against wall time inside processes, and whether to warn (:func:`drift`).

    Slopes are per second on the log scale, means of per-process Theil–Sen slopes t-tested across processes.
    ``baseline_*``: the baseline time's trend, harmless when kernels interleave, so it never raises the flag;
    ``ratio_*``: the log speedup's, ``ratio_change`` its slope times the median process duration;
    ``confound_bias``: per process, the common drift rate times the gap between the kernels' mean start times.
    ``flagged``: a ratio trend or a confound both significant (``p < 1 - confidence``) and above the threshold;
    ``reason`` says which."""

    baseline_slope: float
    baseline_p: float
    ratio_slope: float
    ratio_p: float
    ratio_change: float
    confound_bias: float
    confound_p: float
    flagged: bool
    reason: str
    n: int
    confidence: float


def _theil_sen_slopes(frame: pd.DataFrame, by: str | list[str], x: str, y: str) -> pd.Series:
    """Theil–Sen slope of ``y`` on ``x`` in every group (robust to spikes)."""
    return pd.Series(
        {
            key: float(_scipy_stats().theilslopes(group[y].to_numpy(), group[x].to_numpy())[0])
            for key, group in frame.groupby(by, sort=True)
        }
    )


def _timed_pair(batches: pd.DataFrame, kernel: str, baseline: str, workload_id: str | None) -> pd.DataFrame:
    """The timed batches of the two kernels on one workload, with log ns/test and start time in seconds."""
    _require_columns(batches, ("round", "start_ns"))
    timed = _timed(batches)
    timed = timed.loc[timed["kernel"].isin([kernel, baseline])]
    if workload_id is not None:
        timed = timed.loc[timed["workload_id"] == workload_id]
    if timed["workload_id"].nunique() != 1:
        raise ValueError("select exactly one workload (pass workload_id)")
    if set(timed["kernel"]) != {kernel, baseline}:
        raise ValueError(f"need timed batches of both {kernel!r} and {baseline!r}")
    return timed.assign(log_ns=np.log(timed["ns_per_test"]), t_s=timed["start_ns"] * 1e-9)


def _paired_rounds(timed: pd.DataFrame, kernel: str, baseline: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The rounds pairing the two kernels (same process and round) in processes with 3 or more, and their batches."""
    wide = timed.pivot(index=["process", "round"], columns="kernel", values=["log_ns", "t_s"]).dropna()
    rounds = pd.DataFrame(
        {
            "process": wide.index.get_level_values("process"),
            "log_ratio": (wide["log_ns", baseline] - wide["log_ns", kernel]).to_numpy(),
            "log_base": wide["log_ns", baseline].to_numpy(),
            "t_base": wide["t_s", baseline].to_numpy(),
            "t_pair": ((wide["t_s", baseline] + wide["t_s", kernel]) / 2).to_numpy(),
        }
    )
    # Theil–Sen needs a few rounds; a process with fewer cannot show a trend.
    counts = rounds.groupby("process")["log_ratio"].transform("size")
    rounds = rounds.loc[counts >= 3]
    used = np.unique(rounds["process"])
    if used.size < 2:
        raise ValueError("drift needs at least 2 processes with 3 or more paired rounds")
    return rounds, timed.loc[timed["process"].isin(used)]


def _trends(rounds: pd.DataFrame, timed: pd.DataFrame, confidence: float) -> tuple[float, float, float, float, float]:
    """:class:`Drift`'s first five fields: per-process Theil–Sen slopes of the log baseline time and of the log
    speedup, t-tested across processes, and the speedup's change over the median process."""
    base_slopes = _theil_sen_slopes(rounds, "process", "t_base", "log_base").to_numpy()
    ratio_slopes = _theil_sen_slopes(rounds, "process", "t_pair", "log_ratio").to_numpy()
    base_slope, _, _, base_p = _t_interval(base_slopes, confidence)
    ratio_slope, _, _, ratio_p = _t_interval(ratio_slopes, confidence)
    duration = float(timed.groupby("process")["t_s"].agg(lambda t: t.max() - t.min()).median())
    return base_slope, base_p, ratio_slope, ratio_p, ratio_slope * duration


def _confound(timed: pd.DataFrame, kernel: str, baseline: str, confidence: float) -> tuple[float, float]:
    """The bias of the log speedup from time drift and unequal timing, and its t-test p across processes."""
    # Common drift rate per process, and how far apart in time the kernels ran.
    rate = _theil_sen_slopes(timed, ["process", "kernel"], "t_s", "log_ns").groupby(level=0).mean()
    mean_time = timed.groupby(["process", "kernel"])["t_s"].mean().unstack("kernel")
    gap = mean_time[baseline] - mean_time[kernel]
    bias, _, _, bias_p = _t_interval((rate * gap).to_numpy(), confidence)
    return bias, bias_p


def drift(
    batches: pd.DataFrame,
    kernel: str,
    baseline: str,
    workload_id: str | None = None,
    confidence: float = DEFAULTS.confidence,
    threshold: float = DEFAULTS.drift_threshold,
) -> Drift:
    """Trend tests against wall time, and a time/order confound check, of two kernels (see :class:`Drift`).

    Rounds pair the two kernels. The confound check catches one kernel running later than the other on a
    drifting machine, which no ratio trend shows; ``threshold``: the log-scale size of a drift worth a warning.

    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for p in range(6):
    ...     for r in range(12):
    ...         for pos, k in enumerate(rng.permutation(["base", "new"])):
    ...             t = (r * 2 + pos) * 0.01  # seconds
    ...             slower = 1 + 0.5 * t * (k == "new")  # "new" drifts, "base" does not
    ...             rows.append(dict(process=p, round=r, kernel=k, workload_id="w",
    ...                              warmup=False, tests=1000, start_ns=int(t * 1e9),
    ...                              elapsed_ns=int(2000 * slower * rng.lognormal(0, 0.01))))
    >>> d = drift(pd.DataFrame(rows), kernel="new", baseline="base")
    >>> d.flagged, d.reason, d.ratio_slope < 0
    (True, 'ratio drift', True)
    """
    _check_confidence(confidence)
    timed = _timed_pair(batches, kernel, baseline, workload_id)
    rounds, timed = _paired_rounds(timed, kernel, baseline)
    trends = _trends(rounds, timed, confidence)
    bias, bias_p = _confound(timed, kernel, baseline, confidence)
    ratio_p, ratio_change = trends[3:]
    alpha = 1 - confidence
    reasons = []
    if ratio_p < alpha and abs(ratio_change) > threshold:
        reasons.append("ratio drift")
    if bias_p < alpha and abs(bias) > threshold:
        reasons.append("time confound")
    n = int(np.unique(rounds["process"]).size)
    return Drift(*trends, bias, bias_p, bool(reasons), ", ".join(reasons), n, confidence)


def tukey_outliers(values: npt.ArrayLike, k: float = DEFAULTS.tukey_k) -> np.ndarray:
    """Mask of values outside Tukey's fences ``[Q1 - k IQR, Q3 + k IQR]``: labels only. The quartiles are numpy's
    (linear interpolation), which differ slightly from Tukey's hinges on small samples.

    >>> x = [1, 2, 3, 4, 5, 6, 7, 8, 9, 17, 40]
    >>> tukey_outliers(x).nonzero()[0].tolist(), tukey_outliers(x, k=3.0).nonzero()[0].tolist()
    ([9, 10], [10])
    """
    x = _vector(values, "values")
    q1, q3 = np.quantile(x, [0.25, 0.75])
    spread = k * (q3 - q1)
    return (x < q1 - spread) | (x > q3 + spread)


def label_outliers(batches: pd.DataFrame) -> pd.DataFrame:
    """Copy of ``batches`` with ``ns_per_test``, ``outlier`` and ``far_out`` columns, the fences per kernel,
    workload and process over non-warm-up batches.

    >>> import pandas as pd
    >>> batches = pd.DataFrame({
    ...     "process": [0] * 6, "kernel": ["k"] * 6, "workload_id": ["w"] * 6,
    ...     "warmup": [True] + [False] * 5, "tests": [1] * 6,
    ...     "elapsed_ns": [99, 10, 11, 10, 12, 30]})
    >>> label_outliers(batches)[["elapsed_ns", "outlier", "far_out"]].to_numpy().tolist()
    [[99, False, False], [10, False, False], [11, False, False], [10, False, False], [12, False, False],
     [30, True, True]]
    """
    timed = _timed(batches)
    groups = timed.groupby(_GROUP, sort=False)["ns_per_test"]
    outlier = groups.transform(lambda s: tukey_outliers(s.to_numpy()))
    far_out = groups.transform(lambda s: tukey_outliers(s.to_numpy(), DEFAULTS.tukey_far_k))
    return batches.assign(
        ns_per_test=batches["elapsed_ns"] / batches["tests"],
        outlier=outlier.reindex(batches.index, fill_value=False).astype(bool),
        far_out=far_out.reindex(batches.index, fill_value=False).astype(bool),
    )
