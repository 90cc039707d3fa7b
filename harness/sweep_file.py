"""Sweep files: a :class:`~tribench.harness.plan.Sweep` written as TOML (``tribench sweep --file``).

A sweep file is TOML (read with :mod:`tomllib`); its keys, with an example: docs/commands.md,
"``tribench sweep``". A list in a ``[[workloads]]`` table expands to every combination."""

from __future__ import annotations

import itertools
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

from ..common import UserError, read_user_text
from ..common.renamed import renamed
from ..workloads.kinds import spec_from_dict
from ..workloads.spec import Spec
from .plan import Sequential, Sweep, check_workload_count

__all__ = ["expand_workloads", "load_sweep_file"]


def expand_workloads(table: Mapping[str, Any]) -> list[Spec]:
    """One spec per combination of the list-valued fields of a workload table.

    >>> specs = expand_workloads({"kind": "pairs", "n": 10, "hit_rate": [0.1, 0.9],
    ...                           "dtype": ["float32", "float64"]})
    >>> [(s.hit_rate, s.dtype) for s in specs]
    [(0.1, 'float32'), (0.1, 'float64'), (0.9, 'float32'), (0.9, 'float64')]
    """
    # miss_mix may legitimately be a table; only lists are grid axes.
    axes = {k: v for k, v in table.items() if isinstance(v, list)}
    fixed = {k: v for k, v in table.items() if k not in axes}
    if any(len(v) == 0 for v in axes.values()):
        raise UserError("an empty list in a workload table gives no workloads")
    check_workload_count(math.prod(len(v) for v in axes.values()))  # before building the grid
    return [
        spec_from_dict({**fixed, **dict(zip(axes, combo, strict=True))}) for combo in itertools.product(*axes.values())
    ]


#: The keys a sweep file may have: the arguments of :class:`~tribench.harness.plan.Sweep`.
_TOP_LEVEL = frozenset(f.name for f in fields(Sweep) if f.init)


def load_sweep_file(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Sweep:
    """Read a TOML sweep file (the module's example); every mistake is a UserError naming the file and the key.

    ``overrides`` (the command line's) replace the file's top-level values;
    ``kernel_files`` join the file's; ``None`` values are ignored."""
    path = Path(path)
    text = read_user_text(path, "sweep file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:
        raise UserError(f"{path}: not a sweep file (values nested too deeply to read)") from None
    data = renamed(data, f"{path}: ")  # a sweep file before #52 (a run folder's sweep.toml) spells it "seed"
    unknown = sorted(set(data) - _TOP_LEVEL)
    if unknown:
        raise UserError(f"{path}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(_TOP_LEVEL))}")
    files = data.get("kernel_files", [])
    if isinstance(files, list) and all(isinstance(f, str) for f in files):  # relative to the sweep file
        data["kernel_files"] = [str(path.parent / Path(f).expanduser()) for f in files]
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    if "kernel_files" in given and isinstance(data.get("kernel_files", []), list):  # the flags' join the file's
        given["kernel_files"] = [*data.get("kernel_files", []), *given["kernel_files"]]
    data.update(given)
    if "kernels" not in data or "workloads" not in data:
        raise UserError(f"{path}: a sweep file needs 'kernels' and at least one [[workloads]] table")
    kernels = data["kernels"]
    if not isinstance(kernels, (list, tuple)) or not all(isinstance(k, str) for k in kernels):
        raise UserError(
            f'{path}: kernels: expected a list of kernel names (kernels = ["moller_trumbore"]), got {kernels!r:.80}'
        )
    tables = _as_tables(data.pop("workloads"), path)
    try:  # the grid's size, before any of it is built
        check_workload_count(sum(math.prod(len(v) for v in t.values() if isinstance(v, list)) for t in tables))
    except UserError as exc:
        raise UserError(f"{path}: {exc}") from None
    workloads: list[Spec] = []
    for i, table in enumerate(tables):
        try:
            workloads += expand_workloads(table)
        except UserError as exc:
            raise UserError(f"{path}: workloads[{i}]: {exc}") from None
    try:
        if "workload_kernels" in data:  # which kernels run each workload, in workloads' order
            data["workload_kernels"] = tuple(tuple(_names(k, path)) for k in _names(data["workload_kernels"], path))
        if "sequential" in data:
            rule = dict(_as_tables(data["sequential"], path)[0])
            if set(rule) != {"stage", "target", "budget_s"}:
                raise UserError(f"sequential: expected {{stage = N, target = X, budget_s = S}}, got {rule!r:.80}")
            data["sequential"] = Sequential(**rule)
        return Sweep(workloads=tuple(workloads), **data)
    except UserError as exc:
        where = f"{path} with the command-line flags" if given else str(path)
        raise UserError(f"{where}: {exc}") from None


def _names(value: Any, path: Path) -> list[Any]:
    if not isinstance(value, list):
        raise UserError(f"{path}: workload_kernels: expected a list of lists of kernel names, got {value!r:.80}")
    return value


def _as_tables(value: Any, path: Path) -> Sequence[Mapping[str, Any]]:
    if isinstance(value, Mapping):
        return [value]
    if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
        raise UserError(f"{path}: workloads: expected a list of tables ([[workloads]]), got {value!r:.80}")
    return value
