"""Workload specs: frozen, validated descriptions from which a workload is a pure function.

:func:`workload_id` hashes a spec's canonical JSON, its generator's version and any file's sha256 into the cached
workload's name, so a field that does not apply must stay ``None`` (one workload, one id), and a deliberate change
to a generator's output must bump its version."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

from ..common import UserError
from ..common.renamed import takes_old_seed
from .fields import (
    DTYPES,
    MAX_RAYS,
    canonical_json,
    check_choice,
    check_float,
    check_hit_rate,
    check_int,
    check_sha256,
    checked_mesh_file,
    file_sha256,
)
from .seed.spec import RAY_KINDS, SEED_VERSION, SeedSpec

__all__ = [
    "PAIRS_VERSION",
    "MESHES_VERSION",
    "MISS_STAGES",
    "MISS_MIX_PRESETS",
    "SHAPES",
    "ORDERS",
    "DTYPES",
    "MESH_NAMES",
    "RAY_SETS",
    "RESULTS",
    "ACCELS",
    "PairSpec",
    "MeshSpec",
    "SEED_VERSION",
    "RAY_KINDS",
    "SeedSpec",
    "Spec",
    "identity",
    "workload_id",
    "canonical_json",
]

#: Generator versions: bump when a generator's output for the same spec changes.
PAIRS_VERSION = 2  # 2: the beyond_t_max stage (a t_max array, a new key in every mix)
MESHES_VERSION = 1

#: Why a miss misses, in the order an early-exit kernel meets the stages.
#: Edge e joins vertices v[e-1] and v[e mod 3]: a point is outside edge 1
#: (v0->v1) when v < 0, outside edge 2 (v1->v2) when w < 0, outside edge 3
#: (v2->v0) when u < 0 (u, v, w: weights of v1, v2, v0). ``beyond_t_max``:
#: the ray crosses the triangle, but at ``t >= t_max`` (the ray's own limit).
#: New stages go at the end, so a stage's index keeps its meaning.
MISS_STAGES = (
    "parallel",
    "behind_origin",
    "outside_edge_1",
    "outside_edge_2",
    "outside_edge_3",
    "beyond_t_max",
)

#: Named mixes; ``"edges"`` is the default (see :class:`PairSpec`). ``"uniform"``
#: is over the five stages it had before beyond_t_max (which needs a t_max array).
MISS_MIX_PRESETS = {
    "edges": {"outside_edge_1": 1 / 3, "outside_edge_2": 1 / 3, "outside_edge_3": 1 / 3},
    "uniform": {stage: 1 / 5 for stage in MISS_STAGES[:5]},
    **{stage: {stage: 1.0} for stage in MISS_STAGES},
}

SHAPES = ("sphere", "equilateral", "sliver")
ORDERS = ("shuffled", "sorted")
#: How a pair's triangle is wound toward its ray: at random, or rewound so the ray meets its front face.
WINDINGS = ("random", "facing")
MESH_NAMES = ("suzanne", "icosphere", "uvsphere", "soup", "heightfield")
RAY_SETS = ("camera", "hit_rate", "bounce")
#: What a mesh workload asks of each ray (the kernels' modes other than pairs).
RESULTS = ("closest", "closest_uv", "any")
#: How a mesh workload's kernels run it: every ray against every triangle, or through a BVH.
ACCELS = ("brute", "bvh")

# Sizes beyond these are a typo, not a benchmark (and would exhaust memory).
_MAX_PAIRS = 100_000_000
_MAX_TRIANGLES = 5_000_000
_MIX_TOLERANCE = 1e-6


def _miss_mix(value: Any) -> tuple[tuple[str, float], ...]:
    """Normalise a mix (preset name, mapping or pairs) to a fraction per stage, in stage order."""
    if isinstance(value, str):
        if value not in MISS_MIX_PRESETS:
            raise UserError(
                f"unknown miss_mix {value!r}: choose one of {', '.join(MISS_MIX_PRESETS)} or give a fraction per stage"
            )
        value = MISS_MIX_PRESETS[value]
    try:
        pairs = list(value.items() if isinstance(value, Mapping) else value)
        items = dict(pairs)
    except (TypeError, ValueError):
        raise UserError(f"miss_mix must be a preset name or a fraction per stage, got {value!r:.80}") from None
    if len(items) != len(pairs):  # pairs naming a stage twice: a dict would keep the last one silently
        twice = sorted({str(s) for s, _ in pairs if [t for t, _ in pairs].count(s) > 1})
        raise UserError(f"miss_mix names the stage(s) {', '.join(twice)} twice: give each stage once")
    unknown = sorted(set(items) - set(MISS_STAGES))
    if unknown:
        raise UserError(f"unknown miss stage(s) {unknown}: stages are {', '.join(MISS_STAGES)}")
    mix = tuple((s, check_float(f"miss_mix[{s}]", items.get(s, 0.0))) for s in MISS_STAGES)
    if any(f < 0 for _, f in mix):
        raise UserError(f"miss_mix fractions must be >= 0, got {dict(mix)}")
    total = sum(f for _, f in mix)
    if abs(total - 1.0) > _MIX_TOLERANCE:
        raise UserError(f"miss_mix fractions must sum to 1, got {total:.6g}")
    return mix


@takes_old_seed
@dataclass(frozen=True)
class PairSpec:
    """N (ray, triangle) pairs at an exact per-test hit rate: ``round(hit_rate * n)`` pairs hit.

    ``order``: ``"shuffled"`` or ``"sorted"`` (hits first, then misses by stage). ``miss_mix``: the fraction of the
    misses each stage of :data:`MISS_STAGES` rejects, or a preset; the default, ``"edges"``, spreads them evenly
    over the three edges, as a scene's rejected tests nearly all pass beside a triangle, favouring no kernel's order
    of edge tests.

    >>> PairSpec(n=100, hit_rate=0.3).miss_fractions()["outside_edge_2"]
    0.3333333333333333
    >>> PairSpec(n=10, hit_rate=1.5)
    Traceback (most recent call last):
    ...
    tribench.common.errors.UserError: hit_rate must be in [0, 1], got 1.5
    """

    n: int = 10_000
    hit_rate: float = 0.5
    order: str = "shuffled"
    miss_mix: str | Mapping[str, float] | tuple[tuple[str, float], ...] = "edges"
    shape: str = "sphere"
    scale: float = 1.0
    offset: float = 0.0
    dtype: str = "float64"
    rng_seed: int = 0
    winding: str = "random"

    kind: ClassVar[str] = "pairs"
    mode: ClassVar[str] = "pairs"
    version: ClassVar[int] = PAIRS_VERSION

    def __post_init__(self) -> None:
        put = object.__setattr__  # frozen: normalise the fields once, here
        put(self, "n", check_int("n (number of pairs)", self.n, 1, _MAX_PAIRS))
        put(self, "hit_rate", check_hit_rate(self.hit_rate))
        check_choice("order", self.order, ORDERS)
        put(self, "miss_mix", _miss_mix(self.miss_mix))
        check_choice("shape", self.shape, SHAPES)
        put(self, "scale", check_float("scale", self.scale))
        if self.scale <= 0:
            raise UserError(f"scale must be > 0, got {self.scale}")
        put(self, "offset", check_float("offset", self.offset))
        check_choice("dtype", self.dtype, DTYPES)
        put(self, "rng_seed", check_int("rng_seed", self.rng_seed, 0, 2**63 - 1))
        check_choice("winding", self.winding, WINDINGS)

    def miss_fractions(self) -> dict[str, float]:
        """The target miss-stage mix as ``{stage: fraction}``."""
        assert isinstance(self.miss_mix, tuple)  # __post_init__ normalised it
        return dict(self.miss_mix)

    def to_dict(self) -> dict[str, Any]:
        """JSON- and TOML-friendly fields (no ``None``), with ``kind``."""
        d = asdict(self)
        d["miss_mix"] = self.miss_fractions()
        if self.winding == "random":  # as before the field existed: the same workload ids
            del d["winding"]
        return {"kind": self.kind, **d}

    def targets(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "pairs": self.n,
            "hits": round(self.hit_rate * self.n),
            "hit_rate": self.hit_rate,
            "miss_mix": self.miss_fractions(),
        }
        if self.winding == "facing" and out["hits"]:  # every hit on a front face: a culling kernel's work too
            out["hits_front_facing"] = 1.0
        return out

    def summary(self) -> str:
        mix = ",".join(f"{s}={f:.3g}" for s, f in self.miss_fractions().items() if f)
        extra = "" if (self.scale, self.offset) == (1.0, 0.0) else f" scale={self.scale:g} offset={self.offset:g}"
        facing = " facing" if self.winding == "facing" else ""
        return (
            f"pairs n={self.n} hit_rate={self.hit_rate:g} {self.order} {self.shape}{facing} "
            f"misses[{mix}]{extra} {self.dtype} rng_seed={self.rng_seed}"
        )


@takes_old_seed
@dataclass(frozen=True)
class MeshSpec:
    """A mesh at a target triangle count with rays against it (the ray sets: docs/methodology.md, "What is timed").

    ``mesh``: one of :data:`MESH_NAMES` or a mesh file (refused here if it does not parse); ``triangles``: the
    exact count (None: the base mesh); ``rays``: one of :data:`RAY_SETS` or a ray file's path. ``mesh_sha256`` and
    ``rays_sha256``, when given (a spec read back from a run folder), are trusted without reading the files, so a
    run folder renders after they moved.

    >>> MeshSpec("icosphere", rays="hit_rate").n_rays
    4096
    >>> MeshSpec("icosphere", hit_rate=0.5)
    Traceback (most recent call last):
    ...
    tribench.common.errors.UserError: hit_rate applies to rays='hit_rate' only:
    a camera's hit rate is a result, not a target
    """

    mesh: str = "suzanne"
    triangles: int | None = None
    rays: str = "camera"
    hit_rate: float | None = None
    n_rays: int | None = None
    width: int | None = None
    height: int | None = None
    dtype: str = "float64"
    rng_seed: int = 0
    result: str = "closest"
    accel: str = "brute"
    max_leaf: int | None = None
    mesh_sha256: str | None = None
    rays_sha256: str | None = None

    kind: ClassVar[str] = "mesh"
    version: ClassVar[int] = MESHES_VERSION

    @property
    def mode(self) -> str:
        return self.result

    def __post_init__(self) -> None:
        put = object.__setattr__  # frozen: normalise the fields once, here
        if isinstance(self.mesh, os.PathLike):
            put(self, "mesh", os.fspath(self.mesh))
        if not isinstance(self.mesh, str) or not self.mesh:
            raise UserError(f"mesh must be a name or a file path, got {self.mesh!r}")
        if self.mesh in MESH_NAMES:
            if self.mesh_sha256 is not None:
                raise UserError(f"mesh_sha256 applies to a mesh file only, not to the built-in {self.mesh!r}")
        elif self.mesh_sha256 is None:
            check_choice("dtype", self.dtype, DTYPES)
            put(self, "mesh", checked_mesh_file(self.mesh, MESH_NAMES, self.dtype))
            put(self, "mesh_sha256", file_sha256(self.mesh))
        else:
            check_sha256("mesh_sha256", self.mesh_sha256)
        if self.triangles is not None:
            put(self, "triangles", check_int("triangles", self.triangles, 1, _MAX_TRIANGLES))
        check_choice("dtype", self.dtype, DTYPES)
        if self.rays in RAY_SETS and self.rays_sha256 is not None:
            raise UserError(f"rays_sha256 applies to a ray file only, not to rays={self.rays!r}")
        if self.rays not in RAY_SETS:
            self._ray_file()
        elif self.rays in ("camera", "bounce"):
            for name in ("hit_rate", "n_rays"):
                if getattr(self, name) is not None:
                    raise UserError(
                        f"{name} applies to rays='hit_rate' only: a camera's hit rate is a result, not a target"
                    )
            width = check_int("width", 512 if self.width is None else self.width, 1, 65536)
            height = check_int("height", 512 if self.height is None else self.height, 1, 65536)
            put(self, "width", width)
            put(self, "height", height)
            if width * height > MAX_RAYS:
                raise UserError(f"width x height must be at most {MAX_RAYS} rays")
        else:
            for name in ("width", "height"):
                if getattr(self, name) is not None:
                    raise UserError(f"{name} applies to rays='camera' or 'bounce' only")
            put(self, "hit_rate", check_hit_rate(0.5 if self.hit_rate is None else self.hit_rate))
            put(self, "n_rays", check_int("n_rays", 4096 if self.n_rays is None else self.n_rays, 1, MAX_RAYS))
        put(self, "rng_seed", check_int("rng_seed", self.rng_seed, 0, 2**63 - 1))
        check_choice("result", self.result, RESULTS)
        check_choice("accel", self.accel, ACCELS)
        if self.max_leaf is not None:
            if self.accel != "bvh":
                raise UserError("max_leaf applies to accel='bvh' only: it is the size of a BVH's leaves")
            put(self, "max_leaf", check_int("max_leaf", self.max_leaf, 1, 1024))

    def _ray_file(self) -> None:
        """Check a ray file's path, read its count and hash (unless a recorded hash is given: then trusted)."""
        from . import ray_files

        put = object.__setattr__
        if isinstance(self.rays, os.PathLike):
            put(self, "rays", os.fspath(self.rays))
        for name in ("hit_rate", "width", "height"):
            if getattr(self, name) is not None:
                raise UserError(f"{name} does not apply to a ray file: its rays are given")
        if self.rays_sha256 is not None:  # read back from a run folder or a cache file
            check_sha256("rays_sha256", self.rays_sha256)
            put(self, "n_rays", check_int("n_rays", self.n_rays, 1, ray_files.MAX_FILE_RAYS))
            return
        if self.n_rays is not None:
            raise UserError("n_rays does not apply to a ray file: it has its own count")
        path = Path(self.rays).expanduser() if isinstance(self.rays, str) and self.rays else None
        if path is None or not path.is_file():
            what = "a folder" if path is not None and path.is_dir() else "no such file"
            raise UserError(f"unknown rays {self.rays!r:.200}: not one of {', '.join(RAY_SETS)} and {what}")
        put(self, "rays", str(path.resolve()))
        n, sha256 = ray_files.describe(self.rays, self.dtype)
        put(self, "n_rays", n)
        put(self, "rays_sha256", sha256)

    @property
    def is_file(self) -> bool:
        return self.mesh not in MESH_NAMES

    @property
    def rays_from_file(self) -> bool:
        return self.rays_sha256 is not None

    @property
    def n_rays_total(self) -> int:
        """Number of rays the workload has (bounces: at most, one per camera ray)."""
        if self.rays in ("camera", "bounce"):
            assert self.width is not None and self.height is not None  # __post_init__ set them
            return self.width * self.height
        assert self.n_rays is not None  # __post_init__ set it
        return self.n_rays

    def to_dict(self) -> dict[str, Any]:
        """JSON- and TOML-friendly fields with ``kind``, without None fields and ``accel="brute"``: older ids stay."""
        d = asdict(self)
        if d["accel"] == "brute":
            del d["accel"]
        return {"kind": self.kind, **{k: v for k, v in d.items() if v is not None}}

    def brute_twin(self) -> MeshSpec:
        """The same spec with ``accel="brute"``: the workload whose rays and answers a BVH workload shares."""
        return replace(self, accel="brute", max_leaf=None)

    def targets(self) -> dict[str, Any]:
        t: dict[str, Any] = {"triangles": "base" if self.triangles is None else self.triangles}
        if self.rays == "bounce":  # one per camera hit: a result
            t["primary_rays"] = self.n_rays_total
        else:
            t["rays"] = self.n_rays_total
        if self.rays == "hit_rate":
            assert self.hit_rate is not None and self.n_rays is not None  # __post_init__ set them
            t["ray_hits"] = round(self.hit_rate * self.n_rays)
            t["ray_hit_rate"] = self.hit_rate
        return t

    def summary(self) -> str:
        name = Path(self.mesh).name if self.is_file else self.mesh
        count = "base" if self.triangles is None else str(self.triangles)
        if self.rays == "hit_rate":
            rays = f"{self.n_rays} rays hit_rate={self.hit_rate:g}"
        elif self.rays_from_file:
            rays = f"{self.n_rays} rays from {Path(self.rays).name}"
        else:
            rays = f"{'bounces of camera' if self.rays == 'bounce' else 'camera'} {self.width}x{self.height}"
        result = "" if self.result == "closest" else f" {self.result}"
        accel = "" if self.accel == "brute" else f" {self.accel}"
        accel += "" if self.max_leaf is None else f" max_leaf={self.max_leaf}"
        return f"mesh {name} triangles={count} {rays}{result}{accel} {self.dtype} rng_seed={self.rng_seed}"


Spec = PairSpec | MeshSpec | SeedSpec


def identity(spec: Spec) -> dict[str, Any]:
    """What names a workload: the spec, its generator version, and a file by its sha256 and suffix, never its path."""
    d = {**spec.to_dict(), "version": spec.version}
    d["seed"] = d.pop("rng_seed")  # hashed under its name before #52: every workload keeps its id
    if isinstance(spec, SeedSpec):
        d.update(spec.scene_identity())
    if isinstance(spec, MeshSpec) and spec.is_file:
        d["mesh"] = "file"
        d["mesh_suffix"] = Path(spec.mesh).suffix.lower()  # the spec's own mesh_sha256 names the content
    if isinstance(spec, MeshSpec) and spec.rays_from_file:
        d["rays"] = "file"  # its rays_sha256 names the content
    return d


def workload_id(spec: Spec) -> str:
    """Short stable name of the workload a spec describes: kind and 12 hex digits.

    >>> workload_id(PairSpec(n=5)) == workload_id(PairSpec(n=5.0, hit_rate=0.5))
    True
    >>> workload_id(PairSpec(n=5)).startswith("pairs-")
    True
    """
    digest = hashlib.sha256(canonical_json(identity(spec)).encode()).hexdigest()
    return f"{spec.kind}-{digest[:12]}"
