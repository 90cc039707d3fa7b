"""Variance components and experiment design (Kalibera & Jones 2013)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _check_confidence, _finite, _require_columns, _scipy_stats, _t_quantile, _timed
from .defaults import DEFAULTS


def rounds_matrix(batches: pd.DataFrame, kernel: str, workload_id: str | None = None) -> np.ndarray:
    """Balanced processes x rounds matrix of one kernel's ns/test on one workload, warm-up batches left out.

    Every process keeps its first ``n`` rounds, ``n`` the smallest count: the balanced ANOVA estimators stay
    exact, and the earliest rounds everywhere keep time effects alike across processes.

    >>> import pandas as pd
    >>> batches = pd.DataFrame({
    ...     "process": [0, 0, 0, 1, 1], "round": [0, 1, 2, 0, 1], "kernel": ["k"] * 5,
    ...     "workload_id": ["w"] * 5, "warmup": [False] * 5, "tests": [10] * 5,
    ...     "elapsed_ns": [10, 20, 30, 40, 50]})
    >>> rounds_matrix(batches, "k")
    array([[1., 2.],
           [4., 5.]])
    """
    _require_columns(batches, ("round",))
    timed = _timed(batches)
    timed = timed.loc[timed["kernel"] == kernel]
    if workload_id is not None:
        timed = timed.loc[timed["workload_id"] == workload_id]
    if timed["workload_id"].nunique() != 1:
        raise ValueError("select exactly one workload (pass workload_id)")
    ordered = timed.sort_values(["process", "round"])
    per_process_rounds = [g.to_numpy() for _, g in ordered.groupby("process", sort=True)["ns_per_test"]]
    n = min(len(r) for r in per_process_rounds)
    return np.array([r[:n] for r in per_process_rounds])


@dataclass(frozen=True)
class VarianceComponents:
    """Two-level random-effects model ``y[p, r] = mu + b_p + e_pr`` of one kernel's cost.

    ``between_round`` is ``T1^2 = S1^2``, the mean within-process sample variance; ``between_process`` is
    ``T2^2 = S2^2 - S1^2 / n_rounds`` (``S2^2``: the sample variance of the process means), clipped at 0."""

    between_round: float
    between_process: float
    mean: float
    n_processes: int
    n_rounds: int


def variance_components(matrix: npt.ArrayLike) -> VarianceComponents:
    """Split the variance of a balanced processes x rounds matrix (at least 2 x 2: :func:`rounds_matrix`).

    Kalibera & Jones (2013), "Rigorous Benchmarking in Reasonable Time", level 1 the rounds and level 2 the
    processes: their unbiased (ANOVA) ``T_i^2``, for which the erratum's formula and the original coincide
    at two levels.

    >>> vc = variance_components([[1.0, 3.0], [5.0, 7.0]])
    >>> vc.between_round, vc.between_process, vc.mean
    (2.0, 7.0, 4.0)
    """
    y = np.asarray(matrix, dtype=float)
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 2:
        raise ValueError(f"need at least 2 processes x 2 rounds, got shape {y.shape}")
    _finite(y, "matrix", positive=False)
    n_processes, n_rounds = y.shape
    s1 = float(np.mean(np.var(y, axis=1, ddof=1)))
    s2 = float(np.var(y.mean(axis=1), ddof=1))
    # A negative moment estimate means "no detectable process effect".
    t2 = max(0.0, s2 - s1 / n_rounds)
    return VarianceComponents(s1, t2, float(y.mean()), n_processes, n_rounds)


@dataclass(frozen=True)
class Design:
    """A suggested experiment; ``rel_halfwidth`` is the predicted relative half-width of the mean's interval."""

    rounds_per_process: int
    processes: int
    rel_halfwidth: float
    confidence: float


def suggest_design(
    components: VarianceComponents,
    round_cost: float,
    process_cost: float,
    target_rel_halfwidth: float,
    confidence: float = DEFAULTS.confidence,
    max_rounds: int = DEFAULTS.max_rounds,
    rounds: int | None = None,
) -> Design:
    """Rounds per process and processes needed, from a pilot's components (Kalibera & Jones 2013).

    Rounds: ``ceil(sqrt((c2 / c1) * (T1^2 / T2^2)))`` (``c1 = round_cost``, ``c2 = process_cost``), capped by
    ``max_rounds`` or fixed by ``rounds``. Processes: the smallest ``R >= 2`` with
    ``t_{R-1} * sqrt((T2^2 + T1^2 / I) / R) / mean <= target_rel_halfwidth``. A process's median is noisier than
    its mean for Gaussian rounds (up to ``pi/2`` on ``T1^2``): treat the answer as a lower bound.

    >>> vc = VarianceComponents(between_round=4.0, between_process=1.0, mean=100.0,
    ...                         n_processes=10, n_rounds=10)
    >>> d = suggest_design(vc, round_cost=0.01, process_cost=1.0, target_rel_halfwidth=0.01)
    >>> d.rounds_per_process, d.processes
    (20, 8)
    """
    _check_confidence(confidence)
    if round_cost <= 0 or process_cost < 0 or target_rel_halfwidth <= 0:
        raise ValueError("costs must be positive (process_cost may be 0) and the target positive")
    t1, t2 = components.between_round, components.between_process
    if rounds is not None and rounds < 1:
        raise ValueError(f"rounds must be at least 1, got {rounds}")
    if rounds is None:
        if t1 == 0:
            rounds = 1
        elif t2 == 0:
            rounds = max_rounds
        else:
            rounds = math.ceil(math.sqrt((process_cost / round_cost) * (t1 / t2)))
        rounds = int(min(max(rounds, 1), max_rounds))

    rel_sd = math.sqrt(t2 + t1 / rounds) / abs(components.mean)

    def rel_halfwidth(n: int) -> float:
        return _t_quantile(confidence, n - 1) * rel_sd / math.sqrt(n)

    # The normal approximation never asks for too many; walk up from there.
    z = float(_scipy_stats().norm.ppf(0.5 + confidence / 2))
    processes = max(2, math.ceil((z * rel_sd / target_rel_halfwidth) ** 2))
    while rel_halfwidth(processes) > target_rel_halfwidth:
        processes += 1
    return Design(rounds, processes, rel_halfwidth(processes), confidence)
