"""The workload kinds, in one registry: each ``kind`` names its spec class and its generator.

A spec's ``kind`` (in a cache file, a run folder's ``run.json`` or a sweep file) is looked up here and nowhere else.
A new kind is one spec class in :mod:`.spec`, one generator module, one line in :data:`KINDS` and one in
:func:`generate`.

>>> sorted(KINDS)
['mesh', 'pairs', 'seed']
>>> s = PairSpec(n=5, hit_rate=0.2, miss_mix="uniform")
>>> spec_from_dict(s.to_dict()) == s
True
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from ..common import UserError
from ..common.renamed import renamed
from .spec import MeshSpec, PairSpec, SeedSpec, Spec, workload_id
from .workload import Workload

__all__ = ["KINDS", "generate", "spec_from_dict"]


#: A spec's ``kind`` -> its spec class.
KINDS: dict[str, type] = {"pairs": PairSpec, "mesh": MeshSpec, "seed": SeedSpec}


def _expected() -> str:
    """``'pairs', 'mesh' or 'seed'``."""
    *rest, last = map(repr, KINDS)
    return f"{', '.join(rest)} or {last}"


def spec_from_dict(d: Mapping[str, Any]) -> Spec:
    """Rebuild a spec from its ``to_dict()`` output (the ``kind`` field picks the class)."""
    if not isinstance(d, Mapping):
        raise UserError(f"a workload spec must be a table of fields, got {d!r:.80}")
    d = renamed(d)  # a spec dict written before #52 (a run folder's, a sweep file's, a cache file's)
    kind = d.pop("kind", None)
    if not isinstance(kind, str):
        raise UserError(f"workload kind must be {_expected()}, got {kind!r:.80}")
    if kind not in KINDS:
        raise UserError(f"unknown workload kind {kind!r}: expected {_expected()}")
    cls = KINDS[kind]
    names = {f.name for f in fields(cls)}
    unknown = sorted(map(str, set(d) - names))
    if unknown:
        raise UserError(f"unknown {kind} spec field(s): {', '.join(unknown)}")
    return cls(**d)


def generate(spec: Spec) -> Workload:
    """Build the workload of ``spec`` without touching the cache (its generator's module imported on first use)."""
    if isinstance(spec, PairSpec):
        from .pairs import generate_pairs

        return generate_pairs(spec, workload_id(spec))
    if isinstance(spec, MeshSpec):
        from .rays import generate_mesh_workload  # lazy: pulls in trimesh on use

        return generate_mesh_workload(spec, workload_id(spec))
    from .seed.workload import generate_seed_workload  # lazy: traces a scene on use

    return generate_seed_workload(spec, workload_id(spec))
