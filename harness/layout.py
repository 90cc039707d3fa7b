"""What every timed process does before it times: pinned to one CPU, its memory layout varied at random.

Padding the environment moves the stack, dummy allocations the heap, a random offset of 0-15 elements the data
within cache lines and pages. A layout that suits one contender is then a random effect across processes, not a bias
(Mytkowicz et al., "Producing wrong data without doing anything obviously wrong!", 2009)."""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

__all__ = ["PAD_VARIABLE", "dummy_allocations", "fresh_copy", "padded_env", "padding", "pin"]

#: Environment variable the parent pads to vary the worker's stack position.
PAD_VARIABLE = "TRIBENCH_LAYOUT_PAD"


def padded_env(seed: int, attempt: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default ``os.environ``) padded by 0-4095 bytes drawn from the process's seed and attempt."""
    pad = int(np.random.default_rng([seed, attempt, 1]).integers(0, 4096))
    return {**(os.environ if base is None else base), PAD_VARIABLE: "x" * pad}


def padding() -> int:
    """The bytes of environment padding this process was started with (its rows record them)."""
    return len(os.environ.get(PAD_VARIABLE, ""))


def pin(cpu: int | None) -> None:
    """Pin this process to ``cpu`` (None or a negative number: left unpinned)."""
    if cpu is not None and cpu >= 0 and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {cpu})


def dummy_allocations(rng: np.random.Generator) -> list[bytearray]:
    """A random number of small allocations, kept alive: shifts later heap addresses."""
    return [bytearray(int(size)) for size in rng.integers(16, 4096, size=int(rng.integers(0, 64)))]


def fresh_copy(a: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``a`` copied into a new buffer at a random offset of 0-15 elements."""
    offset = int(rng.integers(0, 16))
    flat = np.empty(a.size + offset, dtype=a.dtype)
    out = flat[offset:].reshape(a.shape)
    out[...] = a
    return out
