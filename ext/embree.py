"""Native Embree, the peer of tribench's BVH: Embree's own C API, timed in C (``ext/peers/embree.c``).

The module is compiled on first use with the installed extension's toolchain against the system's Embree 3
(``libembree-dev``; ``pkg-config embree3`` where it knows it) and cached like a build; where there is none,
:func:`missing` says why in one line. The embreex wheel bundles Embree 4 without its headers, so tribench's
peers time it through Python instead (:mod:`tribench.harness.jobs.peers`)."""

from __future__ import annotations

import functools
import hashlib
import shlex
import subprocess
from types import ModuleType
from typing import NamedTuple

import numpy as np

from ..common import UserError
from .checks import check_array, check_t_max
from .toolchain import EXT, compile_module, import_module, installed, module_file

__all__ = ["INSTALL", "ISAS", "EmbreeMissing", "EmbreeScene", "Trace", "isas_here", "load", "missing", "version"]

#: What to install where Embree is missing.
INSTALL = "apt-get install libembree-dev (Embree 3 headers and library)"

SOURCE = EXT / "peers" / "embree.c"

#: Embree's valid coordinates: |x| at most its FLT_LARGE, for vertices and rays alike. Past it a
#: triangle is dropped silently and a ray fails an assertion that aborts the process (Debian builds
#: Embree with assertions on), so tribench refuses both before C.
LIMIT = 1.844e18

#: The ray widths :meth:`EmbreeScene.trace` calls: rtcIntersect1 and rtcIntersect16.
WIDTHS = (1, 16)

#: The ISAs an :class:`EmbreeScene` may be held to, as Embree's device ``max_isa`` names them
#: (None: Embree picks the widest the CPU has, AVX-512 where there is one).
ISAS = (None, "avx2")


def isas_here() -> tuple[str | None, ...]:
    """The :data:`ISAS` that give Embree a path of its own on this CPU: its pick, and AVX2 where it picks AVX-512."""
    from .probes import probe_isas

    return ISAS if "avx512" in probe_isas() else (None,)


def _within_limit(name: str, a: np.ndarray) -> None:
    largest = float(np.abs(a).max())
    if largest > LIMIT:
        raise UserError(f"{name}: Embree takes coordinates within +-{LIMIT:.4g} (its FLT_LARGE), got {largest:.4g}")


class EmbreeMissing(UserError):
    """Native Embree cannot be compiled or loaded here."""


def _flags() -> tuple[list[str], list[str]]:
    """Embree 3's compile and link flags: pkg-config's, else the default paths (Debian installs no .pc file)."""
    try:
        found = subprocess.run(["pkg-config", "--cflags", "--libs", "embree3"], capture_output=True, text=True)
    except OSError:  # no pkg-config
        found = None
    words = shlex.split(found.stdout) if found is not None and found.returncode == 0 else ["-lembree3"]
    return [w for w in words if not w.startswith(("-l", "-L"))], [w for w in words if w.startswith(("-l", "-L"))]


@functools.cache
def _loaded() -> ModuleType | EmbreeMissing:
    toolchain = installed()
    cflags, libs = _flags()
    key = hashlib.sha256(repr((SOURCE.read_bytes(), toolchain.key, cflags, libs)).encode()).hexdigest()
    name, path = module_file("_embree_", key)
    module = import_module(name, path)
    if module is not None:
        return module

    def failed(result: subprocess.CompletedProcess) -> EmbreeMissing:
        said = next((line for line in result.stderr.splitlines() if "error" in line), result.stderr.strip()[:200])
        return EmbreeMissing(f"native Embree is not available ({said.strip()}); {INSTALL}")

    try:
        compile_module(toolchain, name, path, cflags, failed, sources=(SOURCE,), libs=tuple(libs))
    except EmbreeMissing as e:
        return e
    except UserError as e:  # does not link: no library
        return EmbreeMissing(f"native Embree is not available ({str(e).splitlines()[-1].strip()}); {INSTALL}")
    return import_module(name, path) or EmbreeMissing(f"native Embree compiled, but {path} does not import")


def load() -> ModuleType:
    """The compiled module (compiled now if it is not cached); :class:`EmbreeMissing` where Embree is absent."""
    module = _loaded()
    if isinstance(module, EmbreeMissing):
        raise module
    return module


def missing() -> str | None:
    """Why native Embree cannot run here, in one line, or None when it can."""
    module = _loaded()
    return str(module) if isinstance(module, EmbreeMissing) else None


def version() -> str | None:
    """The Embree version the module was compiled against, or None where it is absent."""
    module = _loaded()
    return None if isinstance(module, EmbreeMissing) else f"Embree {module.version}"


class Trace(NamedTuple):
    """One timed call of :meth:`EmbreeScene.trace`: ``loops`` passes over the rays, timed in C."""

    elapsed_ns: int
    loops: int
    rays: int
    hits: int
    t_sum: float

    @property
    def rays_per_s(self) -> float:
        return self.loops * self.rays / self.elapsed_ns * 1e9 if self.elapsed_ns > 0 else float("nan")


class EmbreeScene:
    """An Embree scene of a float32 triangle array (high build quality, one thread). ``robust`` sets Embree's
    watertight mode; ``isa="avx2"`` holds it to AVX2 (its device's ``max_isa``), as tribench's ``isa`` holds a
    kernel, None lets it pick its widest. ``build_ns``: the build's wall time."""

    def __init__(self, triangles: np.ndarray, robust: bool = False, isa: str | None = None) -> None:
        tris = check_array("triangles", triangles, (3, 3))
        if tris.dtype != np.float32:
            raise UserError(f"Embree takes float32 triangles, got {tris.dtype}")
        if isa not in ISAS:
            raise UserError(f"isa must be one of {', '.join(map(repr, ISAS))}, got {isa!r:.40}")
        _within_limit("triangles", tris)
        self.n_triangles = len(tris)
        self.robust = bool(robust)
        self.isa = isa
        self._scene = load().Scene(tris, len(tris), self.robust, isa)
        self.build_ns: int = self._scene.build_ns

    def _rays(self, origins, directions, t_max) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        o, d = check_array("origins", origins, (3,)), check_array("directions", directions, (3,))
        if o.dtype != np.float32 or d.dtype != np.float32:
            raise UserError(f"Embree takes float32 rays, got {o.dtype} and {d.dtype}")
        if len(o) != len(d):
            raise UserError(f"origins and directions differ in length: {len(o)} and {len(d)}")
        _within_limit("origins", o)
        _within_limit("directions", d)
        return o, d, check_t_max(t_max, len(o), np.dtype(np.float32))

    def intersect(self, origins, directions, t_max=None, width: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Every ray's closest hit: (triangle index, -1 on a miss; t, inf on a miss)."""
        o, d, tm = self._rays(origins, directions, t_max)
        index, t = np.empty(len(o), np.int64), np.empty(len(o), np.float32)
        self._scene.trace(o, d, tm, len(o), _width(width), 1, index, t)
        return index, t

    def trace(self, origins, directions, t_max=None, width: int = 1, loops: int = 1) -> Trace:
        """``loops`` closest-hit passes timed in C: rtcIntersect1 (``width`` 1) or rtcIntersect16 (``width`` 16)."""
        o, d, tm = self._rays(origins, directions, t_max)
        if isinstance(loops, bool) or not isinstance(loops, (int, np.integer)) or loops < 1:
            raise UserError(f"loops must be a positive integer, got {loops!r:.40}")
        elapsed, hits, t_sum = self._scene.trace(o, d, tm, len(o), _width(width), int(loops))
        return Trace(elapsed, int(loops), len(o), hits, t_sum)


def _width(width: object) -> int:
    if width not in WIDTHS or isinstance(width, bool):
        raise UserError(f"width must be 1 (rtcIntersect1) or 16 (rtcIntersect16), got {width!r:.40}")
    return int(width)
