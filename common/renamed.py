"""``seed`` read as ``rng_seed``: #52 renamed every RNG seed, since "seed" is the 2022 paper. What was written
before (a run folder, a sweep file, a spec dict, a spec's keyword) goes through :func:`renamed`, once per format."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping
from typing import Any, TypeVar

from .errors import UserError

__all__ = ["renamed", "takes_old_seed"]

T = TypeVar("T")


def renamed(d: Mapping[str, Any], where: str = "") -> dict[str, Any]:
    """``d`` with its key ``seed`` named ``rng_seed``; both at once are refused (which would win?).

    >>> renamed({"n": 1, "seed": 3})
    {'n': 1, 'rng_seed': 3}
    """
    out = dict(d)
    if "seed" in out:
        if "rng_seed" in out:
            raise UserError(f"{where}seed is the old name of rng_seed: give one of them")
        out["rng_seed"] = out.pop("seed")
    return out


def takes_old_seed(cls: type[T]) -> type[T]:
    """``cls`` also taking ``seed=`` for ``rng_seed=``, and reading ``.seed`` as ``.rng_seed`` with a
    DeprecationWarning (code written before #52); its signature and fields show ``rng_seed`` only."""
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **renamed(kwargs))

    def seed(self: Any) -> int:
        warnings.warn(f"{cls.__name__}.seed is {cls.__name__}.rng_seed now", DeprecationWarning, stacklevel=2)
        return int(self.rng_seed)

    cls.__init__ = __init__  # type: ignore[method-assign]
    cls.seed = property(seed)  # type: ignore[attr-defined]
    return cls
