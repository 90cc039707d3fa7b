"""Workload specs: frozen, validated descriptions from which a workload is a pure function.

Two kinds:

* :class:`PairSpec` -- N independent (ray, triangle) pairs at a target
  per-test hit rate and miss-stage mix (mode ``"pairs"``: ray i vs triangle i);
* :class:`MeshSpec` -- a mesh at a target triangle count with a set of rays,
  pinhole camera rays or rays at a target per-ray hit rate, every ray against
  every triangle; its ``result`` is the mode: ``"closest"`` (the closest
  hit's t), ``"closest_uv"`` (and its barycentrics) or ``"any"`` (some hit,
  as shadow rays ask).

A third kind, :class:`~tribench.workloads.seed_workload.SeedSpec` (the seed's ray
stream), lives in :mod:`~tribench.workloads.seed_workload`.

A spec's identity is its canonical JSON plus its generator version (plus the
sha256 of the file for a mesh read from disk): :func:`workload_id` hashes it
into the short name of the cached workload. Fields that do not apply to a
spec's variant must stay ``None`` (for instance ``hit_rate`` with camera
rays), so that one workload has exactly one id.

Determinism
-----------
Generators draw from ``numpy.random.default_rng(seed)`` (PCG64) and build
pair geometry with ``+ - * /`` and ``sqrt`` only, which IEEE 754 rounds
exactly, so a pair workload's input arrays are the same bytes on any machine
with the same numpy. Meshes also go through trimesh (the UV sphere uses
``sin``/``cos``) and fast-simplification, and the reference answers through
LAPACK: those are identical across processes and machines with the same
library builds. Each workload records the versions it was made with
(``achieved["generated_with"]``); a deliberate change to a generator's output
must bump its version constant, which changes every id it makes.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Union

from tribench.common import UserError

if TYPE_CHECKING:
    from .seed_workload import SeedSpec

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
    "PairSpec",
    "MeshSpec",
    "Spec",
    "spec_from_dict",
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
DTYPES = ("float32", "float64")
MESH_NAMES = ("suzanne", "icosphere", "uvsphere", "soup", "heightfield")
RAY_SETS = ("camera", "hit_rate")
#: What a mesh workload asks of each ray (the kernels' modes other than pairs).
RESULTS = ("closest", "closest_uv", "any")

# Sizes beyond these are a typo, not a benchmark (and would exhaust memory).
_MAX_PAIRS = 100_000_000
_MAX_TRIANGLES = 5_000_000
_MAX_RAYS = 50_000_000
_MIX_TOLERANCE = 1e-6


def _int(name: str, value: Any, lo: int, hi: int) -> int:
    if (isinstance(value, bool) or not isinstance(value, (int, float))
            or (isinstance(value, float) and not value.is_integer())):
        raise UserError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if not lo <= value <= hi:
        raise UserError(f"{name} must be between {lo} and {hi}, got {value}")
    return value


def _float(name: str, value: Any) -> float:
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) < 2**1000:
        value = float(value)  # an int past float64's range is not a finite number
    if not isinstance(value, float) or not math.isfinite(value):
        raise UserError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def _hit_rate(value: Any) -> float:
    h = _float("hit_rate", value)
    if not 0.0 <= h <= 1.0:
        raise UserError(f"hit_rate must be in [0, 1], got {h}")
    return h


def _choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise UserError(f"unknown {name} {value!r}: choose one of {', '.join(choices)}")
    return value


def _miss_mix(value: Any) -> tuple[tuple[str, float], ...]:
    """Normalise a mix (preset name, mapping or pairs) to a fraction per stage, in stage order."""
    if isinstance(value, str):
        if value not in MISS_MIX_PRESETS:
            raise UserError(
                f"unknown miss_mix {value!r}: choose one of {', '.join(MISS_MIX_PRESETS)} "
                f"or give a fraction per stage"
            )
        value = MISS_MIX_PRESETS[value]
    try:
        items = dict(value.items() if isinstance(value, Mapping) else value)
    except (TypeError, ValueError):
        raise UserError(f"miss_mix must be a preset name or a fraction per stage, got {value!r:.80}") from None
    unknown = sorted(set(items) - set(MISS_STAGES))
    if unknown:
        raise UserError(f"unknown miss stage(s) {unknown}: stages are {', '.join(MISS_STAGES)}")
    mix = tuple((s, _float(f"miss_mix[{s}]", items.get(s, 0.0))) for s in MISS_STAGES)
    if any(f < 0 for _, f in mix):
        raise UserError(f"miss_mix fractions must be >= 0, got {dict(mix)}")
    total = sum(f for _, f in mix)
    if abs(total - 1.0) > _MIX_TOLERANCE:
        raise UserError(f"miss_mix fractions must sum to 1, got {total:.6g}")
    return mix


@dataclass(frozen=True)
class PairSpec:
    """N (ray, triangle) pairs at an exact per-test hit rate.

    Parameters
    ----------
    n : int
        Number of pairs (>= 1).
    hit_rate : float
        Target per-test hit rate; exactly ``round(hit_rate * n)`` pairs hit
        (Python's ``round``: halves go to the even count).
    order : {"shuffled", "sorted"}
        Shuffled interleaves hits and misses at random; sorted puts every hit
        first, then the misses grouped by stage.
    miss_mix : str or mapping
        Fraction of the misses rejected at each stage of :data:`MISS_STAGES`,
        or a preset of :data:`MISS_MIX_PRESETS`. The default, ``"edges"``,
        spreads the misses evenly over the three edges: in a scene nearly every
        rejected test is a ray passing beside a triangle in front of it, an
        exactly parallel ray never happens, and an even spread favours no
        kernel's order of edge tests. Behind-origin, parallel and
        beyond-t_max misses are there to be asked for; a mix with
        ``beyond_t_max`` gives the workload a per-ray ``t_max`` array.
    shape : {"sphere", "equilateral", "sliver"}
        Vertices uniform on the unit sphere (Loefstedt & Akenine-Moeller 2005),
        near-equilateral triangles, or slivers (aspect ratio 10 to 1000).
    scale, offset : float
        Every pair is scaled by ``scale`` and moved ``offset`` away from the
        origin along (1, 1, 1): precision experiments.
    dtype : {"float64", "float32"}
    seed : int

    Examples
    --------
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
    miss_mix: Union[str, Mapping[str, float], tuple[tuple[str, float], ...]] = "edges"
    shape: str = "sphere"
    scale: float = 1.0
    offset: float = 0.0
    dtype: str = "float64"
    seed: int = 0

    kind: ClassVar[str] = "pairs"
    mode: ClassVar[str] = "pairs"
    version: ClassVar[int] = PAIRS_VERSION

    def __post_init__(self) -> None:
        put = object.__setattr__  # frozen: normalise the fields once, here
        put(self, "n", _int("n (number of pairs)", self.n, 1, _MAX_PAIRS))
        put(self, "hit_rate", _hit_rate(self.hit_rate))
        _choice("order", self.order, ORDERS)
        put(self, "miss_mix", _miss_mix(self.miss_mix))
        _choice("shape", self.shape, SHAPES)
        put(self, "scale", _float("scale", self.scale))
        if self.scale <= 0:
            raise UserError(f"scale must be > 0, got {self.scale}")
        put(self, "offset", _float("offset", self.offset))
        _choice("dtype", self.dtype, DTYPES)
        put(self, "seed", _int("seed", self.seed, 0, 2**63 - 1))

    def miss_fractions(self) -> dict[str, float]:
        """The target miss-stage mix as ``{stage: fraction}``."""
        return dict(self.miss_mix)

    def to_dict(self) -> dict[str, Any]:
        """JSON- and TOML-friendly fields (no ``None``), with ``kind``."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["miss_mix"] = self.miss_fractions()
        return {"kind": self.kind, **d}

    def targets(self) -> dict[str, Any]:
        """Target figures, keyed like the achieved figures they are compared with."""
        return {
            "pairs": self.n,
            "hits": round(self.hit_rate * self.n),
            "hit_rate": self.hit_rate,
            "miss_mix": self.miss_fractions(),
        }

    def summary(self) -> str:
        """One line for listings."""
        mix = ",".join(f"{s}={f:.3g}" for s, f in self.miss_mix if f)
        extra = "" if (self.scale, self.offset) == (1.0, 0.0) else f" scale={self.scale:g} offset={self.offset:g}"
        return (
            f"pairs n={self.n} hit_rate={self.hit_rate:g} {self.order} {self.shape} "
            f"misses[{mix}]{extra} {self.dtype} seed={self.seed}"
        )


@dataclass(frozen=True)
class MeshSpec:
    """A mesh at a target triangle count with rays against it (closest hit).

    Parameters
    ----------
    mesh : str
        One of :data:`MESH_NAMES` or the path of a mesh file trimesh reads
        (OBJ, PLY, STL, GLB, OFF, ...); a path is stored absolute. A file that
        does not exist, does not parse, or has no triangle of non-zero area
        (so that no hit rate above 0 is possible) is refused here.
    triangles : int or None
        Exact triangle count wanted; ``None`` keeps the base mesh.
    rays : {"camera", "hit_rate"}
        The seed's pinhole camera (``width`` x ``height`` rays), or ``n_rays``
        rays of which exactly ``round(hit_rate * n_rays)`` hit the mesh.
    hit_rate, n_rays : only with ``rays="hit_rate"`` (defaults 0.5 and 4096).
    width, height : only with ``rays="camera"`` (default 512 x 512).
    dtype : {"float64", "float32"}
    seed : int
    result : {"closest", "closest_uv", "any"}
        What is asked of each ray (the kernels' mode); the geometry and the
        reference answers do not depend on it.

    Examples
    --------
    >>> MeshSpec("icosphere", rays="hit_rate").n_rays
    4096
    >>> MeshSpec("icosphere", hit_rate=0.5)
    Traceback (most recent call last):
    ...
    tribench.common.errors.UserError: hit_rate applies to rays='hit_rate' only: a camera's hit rate is a result, not a target
    """

    mesh: str = "suzanne"
    triangles: int | None = None
    rays: str = "camera"
    hit_rate: float | None = None
    n_rays: int | None = None
    width: int | None = None
    height: int | None = None
    dtype: str = "float64"
    seed: int = 0
    result: str = "closest"

    kind: ClassVar[str] = "mesh"
    version: ClassVar[int] = MESHES_VERSION

    @property
    def mode(self) -> str:
        """The kernels' mode: the spec's ``result``."""
        return self.result

    def __post_init__(self) -> None:
        put = object.__setattr__  # frozen: normalise the fields once, here
        if isinstance(self.mesh, os.PathLike):
            put(self, "mesh", os.fspath(self.mesh))
        if not isinstance(self.mesh, str) or not self.mesh:
            raise UserError(f"mesh must be a name or a file path, got {self.mesh!r}")
        if self.mesh not in MESH_NAMES:
            put(self, "mesh", _checked_mesh_file(self.mesh))
        if self.triangles is not None:
            put(self, "triangles", _int("triangles", self.triangles, 1, _MAX_TRIANGLES))
        _choice("rays", self.rays, RAY_SETS)
        if self.rays == "camera":
            for name in ("hit_rate", "n_rays"):
                if getattr(self, name) is not None:
                    raise UserError(
                        f"{name} applies to rays='hit_rate' only: "
                        f"a camera's hit rate is a result, not a target"
                    )
            put(self, "width", _int("width", 512 if self.width is None else self.width, 1, 65536))
            put(self, "height", _int("height", 512 if self.height is None else self.height, 1, 65536))
            if self.width * self.height > _MAX_RAYS:
                raise UserError(f"width x height must be at most {_MAX_RAYS} rays")
        else:
            for name in ("width", "height"):
                if getattr(self, name) is not None:
                    raise UserError(f"{name} applies to rays='camera' only")
            put(self, "hit_rate", _hit_rate(0.5 if self.hit_rate is None else self.hit_rate))
            put(self, "n_rays", _int("n_rays", 4096 if self.n_rays is None else self.n_rays, 1, _MAX_RAYS))
        _choice("dtype", self.dtype, DTYPES)
        put(self, "seed", _int("seed", self.seed, 0, 2**63 - 1))
        _choice("result", self.result, RESULTS)

    @property
    def is_file(self) -> bool:
        """Whether the mesh comes from a file rather than a built-in generator."""
        return self.mesh not in MESH_NAMES

    @property
    def n_rays_total(self) -> int:
        """Number of rays the workload has."""
        return self.width * self.height if self.rays == "camera" else self.n_rays

    def to_dict(self) -> dict[str, Any]:
        """JSON- and TOML-friendly fields (``None`` fields left out), with ``kind``."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        return {"kind": self.kind, **{k: v for k, v in d.items() if v is not None}}

    def targets(self) -> dict[str, Any]:
        """Target figures, keyed like the achieved figures they are compared with."""
        t: dict[str, Any] = {
            "triangles": "base" if self.triangles is None else self.triangles,
            "rays": self.n_rays_total,
        }
        if self.rays == "hit_rate":
            t["ray_hits"] = round(self.hit_rate * self.n_rays)
            t["ray_hit_rate"] = self.hit_rate
        return t

    def summary(self) -> str:
        """One line for listings."""
        name = Path(self.mesh).name if self.is_file else self.mesh
        count = "base" if self.triangles is None else str(self.triangles)
        rays = (
            f"camera {self.width}x{self.height}"
            if self.rays == "camera"
            else f"{self.n_rays} rays hit_rate={self.hit_rate:g}"
        )
        result = "" if self.result == "closest" else f" {self.result}"
        return f"mesh {name} triangles={count} {rays}{result} {self.dtype} seed={self.seed}"


# SeedSpec (the seed's ray stream) lives in seed_workload, which imports this module.
Spec = Union[PairSpec, MeshSpec, "SeedSpec"]


def _checked_mesh_file(path: str) -> str:
    """Absolute path of a readable mesh file, or a UserError saying what is wrong."""
    p = Path(path).expanduser()
    if p.is_dir():
        raise UserError(f"mesh {path!r} is a folder: give a mesh file trimesh reads, or one of {', '.join(MESH_NAMES)}")
    if not p.is_file():
        raise UserError(
            f"unknown mesh {path!r}: not one of {', '.join(MESH_NAMES)} and no such file"
        )
    from .meshes import read_mesh_file  # lazy: trimesh is slow to import

    read_mesh_file(p)  # raises UserError when trimesh cannot make a mesh of it
    return str(p.resolve())


def spec_from_dict(d: Mapping[str, Any]) -> Spec:
    """Rebuild a spec from :meth:`PairSpec.to_dict` / :meth:`MeshSpec.to_dict` output.

    Examples
    --------
    >>> s = PairSpec(n=5, hit_rate=0.2, miss_mix="uniform")
    >>> spec_from_dict(s.to_dict()) == s
    True
    """
    if not isinstance(d, Mapping):
        raise UserError(f"a workload spec must be a table of fields, got {d!r:.80}")
    d = dict(d)
    kind = d.pop("kind", None)
    if not isinstance(kind, str):
        raise UserError(f"workload kind must be 'pairs', 'mesh' or 'seed', got {kind!r:.80}")
    cls = {"pairs": PairSpec, "mesh": MeshSpec}.get(kind)
    if kind == "seed":
        from .seed_workload import SeedSpec

        cls = SeedSpec
    if cls is None:
        raise UserError(f"unknown workload kind {kind!r}: expected 'pairs', 'mesh' or 'seed'")
    names = {f.name for f in fields(cls)}
    unknown = sorted(map(str, set(d) - names))
    if unknown:
        raise UserError(f"unknown {kind} spec field(s): {', '.join(unknown)}")
    return cls(**d)


def canonical_json(obj: Any) -> str:
    """Sorted, compact JSON: equal values give equal strings.

    Examples
    --------
    >>> canonical_json({"b": 1, "a": [0.1, "x"]})
    '{"a":[0.1,"x"],"b":1}'
    """
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _file_sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def identity(spec: Spec) -> dict[str, Any]:
    """What names a workload: the spec, its generator version, a mesh file's content.

    A mesh file enters by its sha256 and suffix (the suffix picks the parser),
    not by its path, so the same file anywhere gives the same id.
    """
    d = {**spec.to_dict(), "version": spec.version}
    if spec.kind == "seed":
        d.update(spec.scene_identity())
    if isinstance(spec, MeshSpec) and spec.is_file:
        d["mesh"] = "file"
        d["mesh_sha256"] = _file_sha256(spec.mesh)
        d["mesh_suffix"] = Path(spec.mesh).suffix.lower()
    return d


def workload_id(spec: Spec) -> str:
    """Short stable name of the workload a spec describes: kind and 12 hex digits.

    Examples
    --------
    >>> workload_id(PairSpec(n=5)) == workload_id(PairSpec(n=5.0, hit_rate=0.5))
    True
    >>> workload_id(PairSpec(n=5)).startswith("pairs-")
    True
    """
    digest = hashlib.sha256(canonical_json(identity(spec)).encode()).hexdigest()
    return f"{spec.kind}-{digest[:12]}"
