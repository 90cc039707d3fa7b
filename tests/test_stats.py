"""Tests of tribench.harness.stats: known answers, and honesty by simulation.

Hand-computed figures use printed t-table values, not scipy, so that an error
shared by the code and the test cannot cancel. The simulations are seeded.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as scipy_stats

from tribench.harness import stats

# --------------------------------------------------------------------------
# A synthetic benchmark with known truth
# --------------------------------------------------------------------------

BASE_NS = 2.0  # true ns/test of the baseline
BATCH_NS = 5_000_000  # wall time between batch starts
TESTS = 1_000_000  # tests per batch: elapsed_ns rounding is negligible


@dataclass(frozen=True)
class Sim:
    """Timings of many experiments, arrays of shape (experiments, processes, rounds, kernels)."""

    ns_per_test: np.ndarray
    start_ns: np.ndarray
    position: np.ndarray
    warmup_rounds: int
    kernels: tuple[str, ...]


def simulate(
    n_experiments: int,
    speedups: tuple[float, ...],
    seed: int,
    design: str = "interleaved",
    drift: float = 0.10,
    kernel_drift: float = 0.0,
    processes: int = 10,
    rounds: int = 20,
    warmup_rounds: int = 2,
) -> Sim:
    """Draw synthetic timings of a baseline and one kernel per entry of ``speedups``.

    log ns/test = true cost
                + process effect  N(0, 0.10)  shared by all kernels of a process
                + layout bias     N(0, 0.02)  per kernel and process: why processes are replicates
                + noise           N(0, 0.03)  per batch
                + spike           log 3 in 2 % of batches
                + drift * (fraction of the process elapsed), common to all kernels
                + kernel_drift * (same fraction), kernel 1 only
                + log 1.5 in warm-up rounds.
    ``design="interleaved"``: every round runs each kernel once, in a fresh random
    order; ``"sequential"``: all of kernel 0's rounds, then all of kernel 1's, ...
    """
    rng = np.random.default_rng(seed)
    n_kernels = 1 + len(speedups)
    n_rounds = warmup_rounds + rounds
    shape = (n_experiments, processes, n_rounds, n_kernels)
    true = np.log(BASE_NS / np.array((1.0, *speedups)))
    process_effect = rng.normal(0.0, 0.10, (n_experiments, processes, 1, 1))
    layout = rng.normal(0.0, 0.02, (n_experiments, processes, 1, n_kernels))
    noise = rng.normal(0.0, 0.03, shape)
    spikes = np.log(3.0) * (rng.random(shape) < 0.02)

    round_index = np.arange(n_rounds)[None, None, :, None]
    kernel_index = np.arange(n_kernels)[None, None, None, :]
    if design == "interleaved":
        position = rng.permuted(np.broadcast_to(kernel_index, shape), axis=-1)
        slot = round_index * n_kernels + position
    elif design == "sequential":
        position = np.zeros(shape, dtype=int)
        slot = np.broadcast_to(kernel_index * n_rounds + round_index, shape)
    else:
        raise ValueError(design)
    elapsed = slot / (n_rounds * n_kernels)
    log_ns = (
        true
        + process_effect
        + layout
        + noise
        + spikes
        + drift * elapsed
        + kernel_drift * elapsed * (kernel_index == 1)
        + np.log(1.5) * (round_index < warmup_rounds)
    )
    process_start = np.arange(processes)[None, :, None, None] * 10**11
    start = process_start + slot.astype(np.int64) * BATCH_NS
    kernels = ("base",) + tuple(f"k{i}" for i in range(1, n_kernels))
    return Sim(np.exp(log_ns), start, position, warmup_rounds, kernels)


def process_medians(sim: Sim) -> np.ndarray:
    """Median ns/test per process of the timed rounds: shape (experiments, processes, kernels)."""
    return np.median(sim.ns_per_test[:, :, sim.warmup_rounds :, :], axis=2)


def batches_of(sim: Sim, experiment: int, workload_id: str = "w") -> pd.DataFrame:
    """The batch table the harness would write for one simulated experiment."""
    _, processes, n_rounds, n_kernels = sim.ns_per_test.shape
    p, r, k = np.meshgrid(np.arange(processes), np.arange(n_rounds), np.arange(n_kernels), indexing="ij")
    ns = sim.ns_per_test[experiment]
    return pd.DataFrame(
        {
            "process": p.ravel(),
            "round": r.ravel(),
            "position": sim.position[experiment].ravel(),
            "kernel": np.array(sim.kernels)[k.ravel()],
            "workload_id": workload_id,
            "warmup": (r < sim.warmup_rounds).ravel(),
            "loops": 1000,
            "tests": TESTS,
            "elapsed_ns": np.rint(ns * TESTS).astype(np.int64).ravel(),
            "start_ns": sim.start_ns[experiment].ravel(),
        }
    )


def coverage(sim: Sim, true_ratio: float, kernel: int = 1) -> float:
    """Fraction of experiments whose speedup interval contains the true ratio."""
    medians = process_medians(sim)
    covered = [(s := stats.speedup(m[:, 0], m[:, kernel])).ci_low <= true_ratio <= s.ci_high for m in medians]
    return float(np.mean(covered))


# --------------------------------------------------------------------------
# per_process, estimate
# --------------------------------------------------------------------------


def test_per_process_by_hand_and_warmups_excluded():
    batches = pd.DataFrame(
        {
            "process": [0, 0, 0, 0, 1, 1, 1],
            "kernel": ["a"] * 7,
            "workload_id": ["w"] * 7,
            "warmup": [True, False, False, False, True, False, False],
            "tests": [10] * 7,
            "elapsed_ns": [1000, 20, 40, 30, 1000, 50, 70],
        }
    )
    table = stats.per_process(batches)
    assert table.columns.tolist() == ["kernel", "workload_id", "process", "ns_per_test", "n_rounds"]
    assert table["ns_per_test"].tolist() == [3.0, 6.0]
    assert table["n_rounds"].tolist() == [3, 2]
    assert len(batches) == 7  # the input is untouched


def test_per_process_rejects_a_warmup_column_that_is_not_bool():
    batches = pd.DataFrame(
        {"process": [0], "kernel": ["a"], "workload_id": ["w"], "warmup": ["False"], "tests": [1], "elapsed_ns": [1]}
    )
    with pytest.raises(TypeError):
        stats.per_process(batches)


def test_per_process_agrees_with_the_numpy_shortcut_of_the_simulation():
    sim = simulate(3, (1.25,), seed=11)
    table = stats.per_process(batches_of(sim, 2))
    wide = table.pivot(index="process", columns="kernel", values="ns_per_test")
    np.testing.assert_allclose(wide[["base", "k1"]].to_numpy(), process_medians(sim)[2], rtol=1e-6)
    assert (table["n_rounds"] == 20).all()


def test_two_processes_at_a_simultaneous_level_give_an_unbounded_interval_not_an_overflow():
    # one degree of freedom at 0.9999: t is about 6366, so the log-scale half-width passes e^709 (#53.1 under load)
    wide = [1.0, 1e150]
    assert stats.estimate(wide, confidence=0.9999).ci_high == math.inf
    assert stats.speedup(wide, [1.0, 1.0], confidence=0.9999).ci_high == math.inf
    assert stats.geometric_mean(wide, confidence=0.9999).ci_high == math.inf
    assert stats.unpaired_ratio(np.log([1.0, 2.0]), np.log(wide), confidence=0.9999).ci_high == math.inf


def test_estimate_t_interval_by_hand():
    # mean 3, sd sqrt(2.5), se sqrt(0.5); t(0.975, 4) = 2.7764 from a printed table; on the log
    # scale the half-width is t se / mean
    e = stats.estimate([1.0, 2.0, 3.0, 4.0, 5.0])
    half = 2.7764 * math.sqrt(0.5) / 3.0
    assert e.mean == 3.0
    assert e.ci_low == pytest.approx(3.0 * math.exp(-half), abs=1e-4)
    assert e.ci_high == pytest.approx(3.0 * math.exp(half), abs=1e-4)
    assert e.sd == pytest.approx(math.sqrt(2.5))
    assert (e.minimum, e.n, e.confidence) == (1.0, 5, 0.95)


def test_estimate_carries_its_confidence_and_narrows_with_it():
    values = [1.0, 2.0, 4.0, 3.0, 5.0, 2.5]
    wide, narrow = stats.estimate(values, 0.99), stats.estimate(values, 0.80)
    assert (wide.confidence, narrow.confidence) == (0.99, 0.80)
    assert wide.ci_low < narrow.ci_low < narrow.ci_high < wide.ci_high


def test_estimate_bootstrap_agrees_with_t_and_is_reproducible():
    values = np.random.default_rng(3).normal(10.0, 1.0, 40)
    e = stats.estimate(values)
    width = e.ci_high - e.ci_low
    assert abs(e.bootstrap_low - e.ci_low) < 0.15 * width
    assert abs(e.bootstrap_high - e.ci_high) < 0.15 * width
    assert stats.estimate(values) == e  # seeded
    assert stats.estimate(values, rng_seed=1).bootstrap_low != e.bootstrap_low


def test_a_time_s_interval_stays_positive_however_few_and_spread_its_processes():
    # two processes far apart: a plain t-interval would read 6.2 [-18.4, 30.7] ns
    e = stats.estimate([3.153, 9.153])
    assert 0 < e.ci_low < e.mean < e.ci_high
    assert e.ci_high / e.mean == pytest.approx(e.mean / e.ci_low)  # symmetric on the log scale
    tight = np.random.default_rng(4).normal(10.0, 0.1, 12)  # 1% spread: the plain t-interval to first order
    t = stats.estimate(tight)
    half = scipy_stats.t.ppf(0.975, 11) * np.std(tight, ddof=1) / math.sqrt(12)
    assert (t.ci_low, t.ci_high) == pytest.approx((t.mean - half, t.mean + half), rel=1e-4)


@pytest.mark.parametrize("values", [[2.0, 2.0, 2.0, 2.0], [1.0, 2.0], [5.0]])
def test_estimate_degenerate_inputs_give_nan_not_errors(values):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e = stats.estimate(values)
    assert math.isnan(e.bootstrap_low) and math.isnan(e.bootstrap_high)
    assert e.mean == np.mean(values) and e.minimum == min(values)
    if len(values) == 1:
        assert math.isnan(e.ci_low) and math.isnan(e.sd)


@pytest.mark.parametrize("bad", [[], [1.0, math.nan], [[1.0, 2.0]]])
def test_estimate_rejects_bad_input(bad):
    with pytest.raises(ValueError):
        stats.estimate(bad)


# --------------------------------------------------------------------------
# speedup, holm, verdict
# --------------------------------------------------------------------------


def test_speedup_by_hand():
    # d = log(baseline) - log(kernel) = [1, 2, 3]: mean 2, sd 1, se 1/sqrt(3);
    # t(0.975, 2) = 4.3027 (printed table). With 2 degrees of freedom the t
    # distribution has a closed form: p = 1 - t / sqrt(2 + t^2), t = 2 sqrt(3).
    s = stats.speedup(np.exp([1.0, 2.0, 3.0]), [1.0, 1.0, 1.0])
    half = 4.3027 / math.sqrt(3)
    t = 2 * math.sqrt(3)
    assert s.ratio == pytest.approx(math.exp(2.0))
    assert math.log(s.ci_low) == pytest.approx(2.0 - half, abs=1e-4)
    assert math.log(s.ci_high) == pytest.approx(2.0 + half, abs=1e-4)
    assert s.p_value == pytest.approx(1 - t / math.sqrt(2 + t * t), rel=1e-9)
    assert (s.n, s.confidence) == (3, 0.95)


def test_speedup_of_an_exact_factor_has_a_zero_width_interval():
    base = np.array([2.0, 3.0, 2.5, 4.0])
    s = stats.speedup(base, base / 1.25)
    assert (s.ratio, s.ci_low, s.ci_high) == pytest.approx((1.25, 1.25, 1.25))


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.1, 10.0), st.floats(0.1, 10.0)), min_size=2, max_size=12))
def test_speedup_swapped_is_the_inverse(pairs):
    base, kern = np.array(pairs).T
    forward, backward = stats.speedup(base, kern), stats.speedup(kern, base)
    assert backward.ratio == pytest.approx(1 / forward.ratio, rel=1e-9)
    assert backward.ci_low == pytest.approx(1 / forward.ci_high, rel=1e-9)
    assert backward.ci_high == pytest.approx(1 / forward.ci_low, rel=1e-9)
    assert backward.p_value == forward.p_value or math.isnan(forward.p_value)


@pytest.mark.parametrize("base, kern", [([1.0, 2.0], [1.0]), ([1.0, 2.0], [1.0, 0.0]), ([1.0, -2.0], [1.0, 1.0])])
def test_speedup_rejects_unpaired_or_non_positive(base, kern):
    with pytest.raises(ValueError):
        stats.speedup(base, kern)


def test_holm_textbook_example():
    # Sorted: 0.005*4 = 0.02, 0.01*3 = 0.03, 0.03*2 = 0.06, 0.04*1 = 0.04 -> max(0.06, 0.04).
    adjusted = stats.holm([0.01, 0.04, 0.03, 0.005])
    np.testing.assert_allclose(adjusted, [0.03, 0.06, 0.06, 0.02])


def test_holm_caps_at_one_and_skips_nan():
    adjusted = stats.holm([0.5, math.nan, 0.4])
    np.testing.assert_allclose(adjusted, [0.8, math.nan, 0.8])
    assert stats.holm([0.9, 0.8]).tolist() == [1.0, 1.0]


@settings(derandomize=True, max_examples=100, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=20))
def test_holm_lies_between_raw_and_bonferroni_and_keeps_the_order(p):
    p = np.array(p)
    adjusted = stats.holm(p)
    assert np.all(adjusted >= p - 1e-15)
    assert np.all(adjusted <= np.minimum(1.0, p.size * p) + 1e-15)
    order = np.argsort(p, kind="stable")
    assert np.all(np.diff(adjusted[order]) >= 0)
    assert adjusted.min() == pytest.approx(min(1.0, p.size * p.min()))


def test_simultaneous_confidence_is_bonferroni():
    assert stats.simultaneous_confidence(0.95, 1) == 0.95
    assert stats.simultaneous_confidence(0.95, 5) == pytest.approx(0.99)
    with pytest.raises(ValueError):
        stats.simultaneous_confidence(0.95, 0)


@pytest.mark.parametrize(
    "low, high, margin, expected",
    [
        (1.05, 1.20, 0.01, "faster"),
        (0.80, 0.97, 0.01, "slower"),
        (0.995, 1.008, 0.01, "equivalent"),
        (1.002, 1.008, 0.01, "equivalent"),  # significant, but inside the margin
        (1 / 1.01, 1.01, 0.01, "equivalent"),  # the bounds belong to the margin
        (0.98, 1.005, 0.01, "inconclusive"),
        (0.90, 1.30, 0.01, "inconclusive"),
        (1.005, 1.02, 0.01, "faster"),  # above 1, straddles the upper bound
        (1.005, 1.02, 0.05, "equivalent"),
        (1.0, 1.0, 0.0, "equivalent"),
        (math.nan, math.nan, 0.01, "inconclusive"),
    ],
)
def test_verdict_table(low, high, margin, expected):
    assert stats.verdict(low, high, margin) == expected


def test_verdict_default_margin_comes_from_defaults():
    assert stats.DEFAULTS.margin == 0.01
    assert stats.verdict(0.995, 1.005) == "equivalent"
    with pytest.raises(ValueError):
        stats.verdict(0.9, 1.1, margin=-0.1)


def test_speedup_table_adjusts_for_multiplicity_per_workload():
    sim = simulate(2, (1.25, 1.0), seed=5, processes=20)
    batches = pd.concat([batches_of(sim, 0, "w1"), batches_of(sim, 1, "w2")], ignore_index=True)
    table = stats.per_process(batches)
    result = stats.speedup_table(table, "base")
    assert len(result) == 4 and set(result["workload_id"]) == {"w1", "w2"}
    np.testing.assert_allclose(result["confidence"], 0.975)  # 2 comparisons per family
    for workload, family in result.groupby("workload_id"):
        np.testing.assert_allclose(family["p_holm"], stats.holm(family["p_value"]))
        w = table[table["workload_id"] == workload].pivot(index="process", columns="kernel", values="ns_per_test")
        direct = stats.speedup(w["base"], w["k1"], 0.975)
        row = family.set_index("kernel").loc["k1"]
        assert (row["ratio"], row["ci_low"], row["ci_high"]) == pytest.approx(
            (direct.ratio, direct.ci_low, direct.ci_high)
        )
    assert (result.loc[result["kernel"] == "k1", "verdict"] == "faster").all()
    expected = [stats.verdict(lo, hi, 0.01) for lo, hi in zip(result["ci_low"], result["ci_high"], strict=True)]
    assert result["verdict"].tolist() == expected


def test_estimate_table_matches_estimate():
    table = stats.per_process(batches_of(simulate(1, (1.25,), seed=2), 0))
    result = stats.estimate_table(table).set_index("kernel")
    direct = stats.estimate(table.loc[table["kernel"] == "k1", "ns_per_test"])
    assert result.loc["k1", "mean"] == direct.mean
    assert result.loc["k1", "bootstrap_high"] == direct.bootstrap_high
    assert result.loc["base", "n"] == 10


# --------------------------------------------------------------------------
# Coverage by simulation: the key honesty test
# --------------------------------------------------------------------------


@pytest.mark.parametrize("true_ratio, seed", [(1.0, 101), (1.25, 202)])
def test_interleaved_design_covers_the_true_ratio(true_ratio, seed):
    sim = simulate(1000, (true_ratio,), seed=seed)
    assert 0.93 <= coverage(sim, true_ratio) <= 0.97


@pytest.mark.slow
def test_sequential_design_under_drift_collapses_and_is_flagged():
    interleaved = simulate(1000, (1.25,), seed=303, design="interleaved")
    sequential = simulate(1000, (1.25,), seed=303, design="sequential")
    assert 0.93 <= coverage(interleaved, 1.25) <= 0.97
    assert coverage(sequential, 1.25) < 0.2
    # Without drift the sequential design is harmless: the check is about drift.
    calm = simulate(1000, (1.25,), seed=303, design="sequential", drift=0.0)
    assert 0.93 <= coverage(calm, 1.25) <= 0.97

    flagged_sequential = [stats.drift(batches_of(sequential, e), "k1", "base") for e in range(20)]
    flagged_interleaved = [stats.drift(batches_of(interleaved, e), "k1", "base") for e in range(40)]
    assert all(d.flagged and "time confound" in d.reason for d in flagged_sequential)
    # Kernel 1 runs later and drift makes later batches slower: the bias is downwards.
    assert all(d.confound_bias < -0.02 for d in flagged_sequential)
    # Flags are tests at 5 %, so an honest design is flagged now and then, rarely.
    assert np.mean([d.flagged for d in flagged_interleaved]) <= 0.1
    assert all(abs(d.confound_bias) < 0.005 for d in flagged_interleaved)


def sequential_stop(medians: np.ndarray, stage: int, target: float, kernel: int = 1) -> int:
    """How many processes of one simulated experiment (``medians``: processes x kernels) a
    sequential sweep runs: stages of ``stage`` processes, stopped once the comparison of
    ``kernel`` with the baseline is narrow by the harness's rule, or at the last process."""
    n = stage
    while n < len(medians):
        base, kern = medians[:n, 0], medians[:n, kernel]
        if n >= stats.MIN_PROCESSES and stats.relative_halfwidth(base, kern) <= target:
            break
        n = min(n + stage, len(medians))
    return n


@pytest.mark.parametrize("stage", [2, 4])
@pytest.mark.parametrize("true_ratio, seed", [(1.0, 505), (1.25, 606)])
def test_stopping_on_the_intervals_width_keeps_their_coverage(true_ratio, seed, stage):
    # The main job's rule (plan.Sequential): stages of 2 processes, a comparison stops once
    # its 95% interval is within +-2% on at least stats.MIN_PROCESSES (8). With this
    # simulation's noise that happens anywhere from 8 to 24 processes, so the rule really
    # acts; the intervals it stops on must still cover the true ratio 93-97% of the time
    # (stages of 2: 93.6% and 94.1%, after 13.5 and 13.9 processes on average; of 4: 93.3%
    # and 94.1%; the fixed design of 24 processes: 95.4% and 95.6%).
    sim = simulate(1000, (true_ratio,), seed=seed, processes=24, rounds=10)
    stops, covered = [], []
    for m in process_medians(sim):
        n = sequential_stop(m, stage=stage, target=0.02)
        s = stats.speedup(m[:n, 0], m[:n, 1])
        stops.append(n)
        covered.append(s.ci_low <= true_ratio <= s.ci_high)
    stops = np.array(stops)
    assert 0.5 < np.mean(stops < 20) and 0.5 < np.mean(stops > 8)  # stopped early often, and late often
    assert len(np.unique(stops)) >= 3
    assert 0.93 <= np.mean(covered) <= 0.97


def test_stopping_on_the_intervals_position_would_not_cover():
    # The control: stopping as soon as the interval excludes 1 (on significance) over an
    # A/A comparison makes false findings, so its intervals miss the truth far too often.
    sim = simulate(1000, (1.0,), seed=707, processes=24, rounds=10)
    covered = []
    for m in process_medians(sim):
        n = 4
        while n < 24 and (s := stats.speedup(m[:n, 0], m[:n, 1])).ci_low <= 1 <= s.ci_high:
            n += 4
        s = stats.speedup(m[:n, 0], m[:n, 1])
        covered.append(s.ci_low <= 1 <= s.ci_high)
    assert np.mean(covered) < 0.9


def test_narrow_comparisons_is_the_width_rule_per_workload():
    sim = simulate(2, (1.25, 1.0), seed=808, processes=8, rounds=10)
    table = pd.concat([stats.per_process(batches_of(sim, e, f"w{e}")) for e in range(2)])
    medians = process_medians(sim)
    widths = {
        (f"w{e}", k): stats.relative_halfwidth(medians[e, :, 0], medians[e, :, i])
        for e in range(2)
        for i, k in ((1, "k1"), (2, "k2"))
    }
    target = float(np.median(list(widths.values())))
    expected = {key for key, w in widths.items() if w <= target}
    narrow = stats.narrow_comparisons(table, {"w0": "base", "w1": "base"}, target)
    assert narrow == expected and 0 < len(narrow) < 4
    # too few processes: nothing is narrow, whatever the width
    assert stats.narrow_comparisons(table, {"w0": "base", "w1": "base"}, 1.0, min_processes=9) == set()
    # a workload without its reference yet stays open
    assert stats.narrow_comparisons(table, {"w0": "k9", "w1": "base"}, 1.0) == {("w1", "k1"), ("w1", "k2")}


@settings(derandomize=True, max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    low=st.floats(0.001, 0.2),
    high=st.floats(0.001, 0.2),
    scale=st.floats(0.01, 100.0),
)
def test_narrow_comparisons_grow_with_the_target_and_ignore_units(seed, low, high, scale):
    sim = simulate(1, (1.1, 0.9, 1.0), seed=seed % 10_000, processes=9, rounds=4, warmup_rounds=1)
    table = stats.per_process(batches_of(sim, 0))
    refs = {"w": "base"}
    small, large = sorted((low, high))
    assert stats.narrow_comparisons(table, refs, small) <= stats.narrow_comparisons(table, refs, large)
    # a width is relative: the same run timed in other units stops the same comparisons
    scaled = table.assign(ns_per_test=table["ns_per_test"] * scale)
    assert stats.narrow_comparisons(scaled, refs, large) == stats.narrow_comparisons(table, refs, large)


def test_aa_summary_on_honest_and_on_naive_intervals():
    sim = simulate(1000, (1.0,), seed=404)
    medians = process_medians(sim)
    honest = stats.aa_summary([stats.speedup(m[:, 0], m[:, 1]) for m in medians])
    assert 0.93 <= honest.coverage <= 0.97
    assert 0.03 <= honest.false_positive_rate <= 0.07
    assert honest.ks_p_value > 0.01
    assert honest.margin == pytest.approx(math.expm1(honest.noise_floor))
    assert 0.005 < honest.margin < 0.05

    # Treating the batches of a process as independent replicates ignores the
    # layout bias: the intervals are too narrow and the A/A check says so.
    timed = sim.ns_per_test[:, :, sim.warmup_rounds :, :]
    naive = stats.aa_summary([stats.speedup(t[..., 0].ravel(), t[..., 1].ravel()) for t in timed])
    assert naive.coverage < 0.93
    assert naive.ks_p_value < 1e-3


def test_aa_noise_floor_by_hand():
    log_ratios = np.arange(1, 42) * np.where(np.arange(41) % 2, -1.0, 1.0)
    # |x| = 1..41; the 0.975 quantile sits at index 0.975 * 40 = 39 -> 40.
    assert stats.aa_noise_floor(log_ratios) == pytest.approx(40.0)


# --------------------------------------------------------------------------
# Variance components and design
# --------------------------------------------------------------------------


def test_variance_components_by_hand():
    # Within: var([1, 3]) = var([5, 7]) = 2. Process means 2 and 6: S2^2 = 8.
    vc = stats.variance_components([[1.0, 3.0], [5.0, 7.0]])
    assert (vc.between_round, vc.between_process) == (2.0, 8.0 - 2.0 / 2)
    # Means equal, within variance 5: S2^2 - S1^2 / 2 = -2.5, clipped to 0.
    assert stats.variance_components([[1.0, 5.0], [2.0, 4.0]]).between_process == 0.0


def test_variance_components_recover_known_truth():
    rng = np.random.default_rng(7)
    processes, rounds, between_process, between_round = 400, 20, 4.0, 9.0
    y = (
        50.0
        + rng.normal(0, math.sqrt(between_process), (processes, 1))
        + rng.normal(0, math.sqrt(between_round), (processes, rounds))
    )
    vc = stats.variance_components(y)
    assert vc.between_round == pytest.approx(between_round, rel=0.05)
    assert vc.between_process == pytest.approx(between_process, rel=0.25)
    assert (vc.n_processes, vc.n_rounds) == (processes, rounds)
    assert vc.mean == pytest.approx(50.0, abs=0.3)


def test_rounds_matrix_balances_by_keeping_the_first_rounds():
    batches = pd.DataFrame(
        {
            "process": [0, 0, 0, 0, 1, 1, 1, 0],
            "round": [0, 1, 2, 3, 0, 1, 2, 1],
            "kernel": ["k"] * 7 + ["other"],
            "workload_id": ["w"] * 8,
            "warmup": [True, False, False, False, True, False, False, False],
            "tests": [1] * 8,
            "elapsed_ns": [99, 3, 1, 2, 99, 7, 8, 1000],
        }
    )
    np.testing.assert_array_equal(stats.rounds_matrix(batches, "k"), [[3.0, 1.0], [7.0, 8.0]])
    two_workloads = pd.concat([batches, batches.assign(workload_id="v")])
    with pytest.raises(ValueError):
        stats.rounds_matrix(two_workloads, "k")
    assert stats.rounds_matrix(two_workloads, "k", "v").shape == (2, 2)


def test_suggest_design_by_hand():
    vc = stats.VarianceComponents(between_round=9.0, between_process=4.0, mean=50.0, n_processes=10, n_rounds=10)
    design = stats.suggest_design(vc, round_cost=1.0, process_cost=16.0, target_rel_halfwidth=0.02)
    # Rounds: ceil(sqrt(16 * 9 / 4)) = 6. Relative sd of a process mean:
    # sqrt(4 + 9/6) / 50 = 0.046904. Printed t-table: t(22) = 2.074 gives
    # 2.074 * 0.046904 / sqrt(23) = 0.02028 > 0.02; t(23) = 2.069 gives
    # 2.069 * 0.046904 / sqrt(24) = 0.01981 <= 0.02: 24 processes.
    assert design.rounds_per_process == 6
    assert design.processes == 24
    assert design.rel_halfwidth == pytest.approx(0.01981, abs=1e-4)


def test_suggest_design_with_rounds_fixed_by_hand():
    vc = stats.VarianceComponents(between_round=9.0, between_process=4.0, mean=50.0, n_processes=10, n_rounds=10)
    design = stats.suggest_design(
        vc, round_cost=1.0, process_cost=16.0, target_rel_halfwidth=0.02, rounds=1, max_rounds=1
    )
    # Rounds kept at 1: relative sd sqrt(4 + 9) / 50 = 0.072111. t(52) = 2.0066:
    # 2.0066 * 0.072111 / sqrt(53) = 0.019876 <= 0.02, while t(51) = 2.0076 gives
    # 2.0076 * 0.072111 / sqrt(52) = 0.020076 > 0.02: 53 processes.
    assert design.rounds_per_process == 1
    assert design.processes == 53
    # fixed rounds are not capped by max_rounds, and must be at least 1
    assert stats.suggest_design(vc, 1.0, 16.0, 0.02, rounds=40, max_rounds=10).rounds_per_process == 40
    with pytest.raises(ValueError):
        stats.suggest_design(vc, 1.0, 16.0, 0.02, rounds=0)


def test_suggest_design_edge_cases():
    no_process_effect = stats.VarianceComponents(9.0, 0.0, 50.0, 10, 10)
    assert stats.suggest_design(no_process_effect, 1.0, 16.0, 0.02, max_rounds=50).rounds_per_process == 50
    no_round_noise = stats.VarianceComponents(0.0, 4.0, 50.0, 10, 10)
    assert stats.suggest_design(no_round_noise, 1.0, 16.0, 0.02).rounds_per_process == 1
    # More expensive processes -> more rounds in each.
    vc = stats.VarianceComponents(9.0, 4.0, 50.0, 10, 10)
    assert (
        stats.suggest_design(vc, 1.0, 100.0, 0.02).rounds_per_process
        > stats.suggest_design(vc, 1.0, 1.0, 0.02).rounds_per_process
    )


def test_pilot_to_design_on_simulated_batches():
    sim = simulate(1, (1.25,), seed=9, processes=30, rounds=40, drift=0.0)
    vc = stats.variance_components(stats.rounds_matrix(batches_of(sim, 0), "base"))
    # Truth on the log scale: process sd 0.1 (+ layout 0.02), batch sd 0.03 plus
    # spikes; in ns at 2 ns/test the process part dominates.
    assert vc.between_process > vc.between_round / 40
    assert vc.mean == pytest.approx(BASE_NS, rel=0.1)


# --------------------------------------------------------------------------
# Crossover and scaling
# --------------------------------------------------------------------------

HIT_RATES = np.array([0.1, 0.3, 0.5, 0.7, 0.9])


def plain_t_interval(values) -> tuple[float, float, float]:
    """Mean and 95% Student-t interval, by hand (a slope or a root may be negative, unlike a time)."""
    x = np.asarray(values, dtype=float)
    half = scipy_stats.t.ppf(0.975, x.size - 1) * np.std(x, ddof=1) / math.sqrt(x.size)
    return float(x.mean()), float(x.mean() - half), float(x.mean() + half)


def test_crossover_reduces_to_root_t_interval_when_slopes_are_equal():
    # Equal slopes: Fieller's interval is the t-interval of per-process roots.
    shifts = np.array([0.02, -0.01, 0.03, 0.0, -0.02, 0.01])
    lines = -2.0 * (HIT_RATES[None, :] - 0.45) + shifts[:, None]
    c = stats.crossover(HIT_RATES, lines)
    roots = 0.45 + shifts / 2.0
    mean, low, high = plain_t_interval(roots)
    assert c.hit_rate == pytest.approx(mean)
    assert (c.ci_low, c.ci_high) == pytest.approx((low, high))
    assert (c.slope, c.n) == (pytest.approx(-2.0), 6)


def test_crossover_covers_a_known_root():
    rng = np.random.default_rng(21)
    covered = []
    for _ in range(500):
        slopes = rng.normal(-1.0, 0.3, (10, 1))
        lines = slopes * (HIT_RATES - 0.4) + rng.normal(0, 0.05, (10, 1)) + rng.normal(0, 0.02, (10, 5))
        c = stats.crossover(HIT_RATES, lines)
        covered.append(c.ci_low <= 0.4 <= c.ci_high)
    assert 0.92 <= np.mean(covered) <= 0.98


def test_crossover_without_a_crossing_in_range_is_nan():
    always_faster = 0.5 + 0.1 * HIT_RATES[None, :] + np.array([[0.0], [0.01], [-0.01]])
    c = stats.crossover(HIT_RATES, always_faster)
    assert math.isnan(c.hit_rate) and math.isnan(c.ci_low) and math.isnan(c.ci_high)
    assert c.slope == pytest.approx(0.1)
    outside = -1.0 * (HIT_RATES - 1.5)[None, :] + np.array([[0.0], [0.01]])  # crosses at 1.5
    assert math.isnan(stats.crossover(HIT_RATES, outside).hit_rate)
    flat = np.zeros((3, 5)) + np.array([[0.01], [-0.01], [0.0]])
    assert math.isnan(stats.crossover(HIT_RATES, flat).hit_rate)


def test_crossover_interval_is_nan_when_the_slope_is_not_significant():
    lines = np.array([[1.0], [-1.0], [0.5]]) * (HIT_RATES - 0.5) + np.array([[0.01], [0.0], [-0.01]])
    c = stats.crossover(HIT_RATES, lines)
    assert 0.1 <= c.hit_rate <= 0.9
    assert math.isnan(c.ci_low) and math.isnan(c.ci_high)


def test_scaling_slope_on_exact_power_law():
    sizes = np.array([100.0, 1_000.0, 10_000.0, 100_000.0])
    cost = np.array([[3.0], [3.3], [2.9]]) * sizes**0.4
    s = stats.scaling_slope(sizes, cost)
    assert (s.slope, s.ci_low, s.ci_high) == pytest.approx((0.4, 0.4, 0.4))
    assert math.exp(s.intercept) == pytest.approx((3.0 * 3.3 * 2.9) ** (1 / 3))


def test_scaling_slope_matches_per_process_regressions():
    from scipy.stats import linregress

    rng = np.random.default_rng(8)
    sizes = np.geomspace(1e3, 1e6, 7)
    cost = 2.0 * sizes**0.3 * rng.lognormal(0, 0.05, (12, 7)) * rng.lognormal(0, 0.1, (12, 1))
    s = stats.scaling_slope(sizes, cost)
    slopes = [linregress(np.log(sizes), np.log(row)).slope for row in cost]
    assert (s.slope, s.ci_low, s.ci_high) == pytest.approx(plain_t_interval(slopes))
    assert s.ci_low <= 0.3 <= s.ci_high


# --------------------------------------------------------------------------
# Drift and outliers
# --------------------------------------------------------------------------


def test_drift_flags_a_kernel_that_drifts_alone():
    drifting = simulate(5, (1.25,), seed=31, kernel_drift=0.10)
    results = [stats.drift(batches_of(drifting, e), "k1", "base") for e in range(5)]
    assert all(d.flagged and "ratio drift" in d.reason for d in results)
    # k1 slows down over the process, so its speedup falls.
    assert all(d.ratio_slope < 0 and d.ratio_change < -0.05 for d in results)


def test_drift_does_not_flag_common_drift_when_interleaved():
    common = simulate(5, (1.25,), seed=31)
    results = [stats.drift(batches_of(common, e), "k1", "base") for e in range(5)]
    assert not any(d.flagged for d in results)
    assert all(d.reason == "" for d in results)
    # The common drift is visible in the baseline (0.1 across a 0.22 s process).
    assert all(d.baseline_slope > 0.2 and d.baseline_p < 0.05 for d in results)


def test_drift_needs_one_workload():
    sim = simulate(2, (1.25,), seed=1)
    batches = pd.concat([batches_of(sim, 0, "a"), batches_of(sim, 1, "b")])
    with pytest.raises(ValueError):
        stats.drift(batches, "k1", "base")
    assert stats.drift(batches, "k1", "base", workload_id="b").n == 10


def test_tukey_by_hand():
    # Quartiles (linear) of 1..9, 17, 40: Q1 = 3.5, Q3 = 8.5, IQR = 5.
    # Fences: 1.5 IQR -> [-4, 16]; 3 IQR -> [-11.5, 23.5].
    x = [1, 2, 3, 4, 5, 6, 7, 8, 9, 17, 40]
    assert stats.tukey_outliers(x).tolist() == [False] * 9 + [True, True]
    assert stats.tukey_outliers(x, k=3.0).tolist() == [False] * 10 + [True]
    on_fence = [1, 2, 3, 4, 5, 6, 7, 8, 9, 16, 40]  # same quartiles: 16 sits on the fence
    assert stats.tukey_outliers(on_fence).tolist() == [False] * 10 + [True]


def test_label_outliers_labels_and_keeps_every_row():
    batches = batches_of(simulate(1, (1.25,), seed=4, drift=0.0), 0)
    spiked = batches.index[(batches["process"] == 3) & (batches["kernel"] == "k1") & (batches["round"] == 10)]
    batches.loc[spiked, "elapsed_ns"] *= 10
    labelled = stats.label_outliers(batches)
    assert len(labelled) == len(batches)
    assert labelled.loc[spiked, "outlier"].all() and labelled.loc[spiked, "far_out"].all()
    assert not labelled.loc[labelled["warmup"], "outlier"].any()
    assert (labelled["far_out"] <= labelled["outlier"]).all()
    # Spikes (2 % x3) and their Tukey labels are few.
    assert labelled["outlier"].mean() < 0.1
    assert "outlier" not in batches.columns  # pure: the input is not modified


# ------------------------------------------------------------------ the interval as text


@settings(max_examples=200, deadline=None)
@given(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([".3g", ".4g", ".3f"]),
    st.sampled_from(["", "×", " s"]),
)
def test_format_interval_writes_the_estimate_then_its_bounds_or_says_there_is_none(value, low, high, spec, unit):
    text = stats.format_interval(value, low, high, spec, unit)
    bounds = f"[{low:{spec}}, {high:{spec}}]" if math.isfinite(low) and math.isfinite(high) else "[no interval]"
    shown = f"{value:{spec}}" if math.isfinite(value) else "–"
    assert text == f"{shown}{unit} {bounds}"
    assert stats.format_interval(None, low, high, spec, unit) == bounds  # the interval alone, no unit
