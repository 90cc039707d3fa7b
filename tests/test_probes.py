"""The throughput probes and the port model (tribench.harness.peak): rates are
positive and finite on every runnable ISA, the model's arithmetic gives known
answers, and every kernel's per-class mix adds up to its operation count."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.common import UserError
from tribench.harness.peak import ALU_CLASSES, bound_from_mix


@pytest.mark.parametrize("isa", ext.probe_isas())
def test_probes_give_positive_finite_rates_on_every_runnable_isa(isa):
    t = ext.op_throughput(isa, target_ns=2e5, repeats=1)
    assert t.isa == isa
    for rates in (t.float32, t.float64):
        assert set(rates) == set(ext.OP_CLASSES)
        assert all(math.isfinite(r) and r > 0 for r in rates.values()), rates


def test_an_isa_the_cpu_cannot_run_is_a_user_error():
    with pytest.raises(UserError, match="isa must be one of"):
        ext.op_throughput("neon")


@pytest.mark.parametrize("kernel", ext.kernel_names(internal=True))
def test_every_kernel_mix_sums_to_its_operation_count(kernel):
    info = ext.kernel_info(kernel)
    mix = info.mix
    assert set(mix) == {"fma", "mul", "add", "cmp", "div", "logic", "load"}
    assert sum(mix[c] for c in ("fma", "mul", "add", "cmp", "div")) == info.ops
    assert mix["load"] == info.stride and all(v >= 0 for v in mix.values())


RATES = {"fma": 2.0, "mul": 2.0, "add": 2.0, "cmp": 1.0, "logic": 2.0, "div": 0.25, "load": 2.0, "fma_add": 2.0}


@pytest.mark.parametrize(
    ("mix", "rates", "expected"),
    [
        ({"fma": 10}, RATES, 5.0),  # FMA pipes alone
        ({"mul": 4, "add": 4}, RATES, 4.0),  # adds share the FMA pipes: summed
        ({"mul": 4, "add": 4}, {**RATES, "fma_add": 4.0}, 2.0),  # own adders: the mix's rate, and mul alone
        ({"mul": 6, "add": 2}, {**RATES, "fma_add": 4.0}, 3.0),  # muls bind on their own pipes
        # own adders, multiplies on the FMA pipes (a Zen core): fma + mul bind, 8 / 2, not 12 / 4
        ({"fma": 4, "mul": 4, "add": 4}, {**RATES, "fma_add": 4.0, "fma_mul": 2.0}, 4.0),
        ({"fma": 4, "mul": 4}, {**RATES, "fma_mul": 4.0}, 2.0),  # a core whose multiplies had pipes of their own
        ({"div": 1, "add": 1}, RATES, 4.0),  # the divider binds
        ({"cmp": 2, "logic": 2, "add": 2}, RATES, 3.0),  # the vector-ALU pool: 6 ops at 2 per ns
        ({"add": 1, "load": 9}, RATES, 4.5),  # loads bind
    ],
)
def test_port_model_known_answers(mix, rates, expected):
    assert bound_from_mix(mix, rates) == pytest.approx(expected)


@settings(max_examples=50, deadline=None)
@given(st.dictionaries(st.sampled_from([*ALU_CLASSES, "load"]), st.integers(0, 100)), st.sampled_from(ALU_CLASSES))
def test_port_model_is_at_least_each_class_alone_and_grows_with_work(mix, more):
    bound = bound_from_mix(mix, RATES)
    assert all(bound >= n / RATES[c] - 1e-12 for c, n in mix.items())
    assert bound_from_mix({**mix, more: mix.get(more, 0) + 1}, RATES) >= bound
