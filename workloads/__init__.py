"""Workloads: meshes and ray sets from frozen specs with float64 reference answers, their caches and pictures,
and the robustness suite's cases (:mod:`.robustness`); nothing here times anything. It may import
``tribench.common`` and ``tribench.ext`` (to count a stream's tests); importing it does not import trimesh or
matplotlib."""

from . import robustness
from .cache import CachedWorkload, CacheWarning, cache_dir, generate, list_cached, load, make
from .kinds import spec_from_dict
from .pairs import classify_misses
from .reference import PairAnswers, intersect_closest, intersect_pairs
from .spec import MISS_STAGES, MeshSpec, PairSpec, workload_id
from .workload import Workload

__all__ = [
    "PairAnswers",
    "intersect_closest",
    "intersect_pairs",
    "MISS_STAGES",
    "PairSpec",
    "MeshSpec",
    "spec_from_dict",
    "workload_id",
    "Workload",
    "make",
    "load",
    "generate",
    "list_cached",
    "cache_dir",
    "CacheWarning",
    "CachedWorkload",
    "classify_misses",
    "robustness",
]
