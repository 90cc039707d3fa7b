"""The kernel registry as Python reads it: names, declared properties, modes and build, every property from
the compiled module (``ext/kernels/list.h`` and the kernels' files), none inferred from a kernel's name."""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from types import ModuleType
from typing import Literal

import numpy as np

from ..common import UserError, UserTypeError
from ..common.files import file_sha256
from . import _core
from .checks import check_dtype_name, check_flag

Mode = Literal["pairs", "any", "closest", "closest_uv"]
MODES: tuple[str, ...] = ("pairs", "any", "closest", "closest_uv")  # the C enum's order
_PUBLIC: tuple[str, ...] = _core.kernel_names(False)
_COMPILED: tuple[str, ...] = _core.kernel_names(True)
# every name a call accepts: a kernel this CPU runs in none of its ISAs (the AVX2 yardstick on aarch64) is left out
_KERNELS: tuple[str, ...] = tuple(k for k in _COMPILED if any(ok for _, ok in _core.kernel_info(k)["isas"]))
BUILT_IN: frozenset[str] = frozenset(_KERNELS)
# The compiled module that holds each kernel: _core, or a kernel file's own
# build (kernel_files.py), which joins its kernels with adopt().
_MODULES: dict[str, ModuleType] = dict.fromkeys(_KERNELS, _core)
_FILES: dict[str, str] = {}  # a kernel file's kernel -> the file


def kernel_names(internal: bool = False) -> tuple[str, ...]:
    """Names of the registered kernels, in registry order; ``internal`` adds the harness's honesty-check kernels.

    >>> "moller_trumbore" in kernel_names()
    True
    >>> [k for k in kernel_names(internal=True) if k not in kernel_names()]  # doctest: +NORMALIZE_WHITESPACE
    ['moller_trumbore_aa', 'moller_seed_aa', 'moller_seed_object', 'curless_seed_object',
     'moller_trumbore_same', 'moller_trumbore_twice', 'moller_trumbore_yardstick']
    """
    return _KERNELS if check_flag("internal", internal) else _PUBLIC


@dataclass(frozen=True)
class KernelInfo:
    """What the registry says of one kernel, each property declared once (docs/kernels.md, "Where a kernel's
    properties live") and read here from the extension.

    ``lanes``: triangles per record block (1 scalar, 16 native); ``stride``: reals prepared per triangle;
    ``ops``: arithmetic operations per test by ``ext/kernels.h``'s counting rules. ``isas``: the ISAs compiled,
    best first, each with whether this CPU runs it; ``isa``: the one calls use (``TRIBENCH_ISA`` if runnable,
    else the best). ``algorithm``: the clean scalar kernel this is a form of, which rankings group by.
    ``flat``: ``"miss"`` or ``"as_is"`` (the kernel's own test decides). ``source``: ``"built-in"`` or the
    kernel file that declared it, whose paper is ``citation``."""

    name: str
    lanes: int
    stride: int
    ops: int
    internal: bool
    isas: dict
    isa: str
    algorithm: str
    culls_back_faces: bool
    watertight: str
    watertight_source: str
    seed_replay: bool
    flat: str
    precisions: tuple[str, ...]
    source: str = "built-in"
    citation: str = ""

    @property
    def mix(self) -> dict[str, int]:
        """Operations per test (and lane) by class: ``fma, mul, add, cmp, div`` (summing to :attr:`ops`), ``logic``
        (mask and select work, outside ``ops``) and ``load`` (the stride); declared as ``tb_<name>_mix``, and a
        native kernel's is its compiled loop's (tests/test_ext_build.py)."""
        counts = dict(
            zip(("fma", "mul", "add", "cmp", "div", "logic"), core_of(self.name).kernel_mix(self.name), strict=True)
        )
        return {**counts, "load": self.stride}

    @property
    def modes(self) -> tuple[str, ...]:
        """Modes the kernel runs (native kernels have no pairs mode)."""
        return MODES if self.lanes == 1 else MODES[1:]

    @property
    def bytes_per_triangle(self) -> dict[str, int]:
        """Bytes of prepared data per triangle, per precision (stride x itemsize)."""
        return {p: self.stride * np.dtype(p).itemsize for p in self.precisions}


def kernel_info(kernel: str) -> KernelInfo:
    """Lanes, storage, instruction sets and declared properties of ``kernel``.

    >>> kernel_info("moller_trumbore").isa
    'scalar'
    >>> info = kernel_info("moller_trumbore_fma")
    >>> info.lanes, info.isas["baseline"], info.algorithm
    (16, True, 'moller_trumbore')
    >>> kernel_info("woop").watertight, kernel_info("moller_trumbore_cull").culls_back_faces
    ('edges_and_vertices', True)
    """
    module = core_of(kernel)
    declared = dict(module.kernel_info(kernel))  # afresh: which ISAs run can be asked again
    isas = declared.pop("isas")
    runnable = dict(isas)
    wanted = os.environ.get("TRIBENCH_ISA")
    if declared["lanes"] > 1 and wanted:
        if not runnable.get(wanted):
            raise UserError(
                f"TRIBENCH_ISA={wanted!r} cannot run {kernel}: runnable here: {', '.join(i for i, ok in isas if ok)}"
            )
        isa = wanted
    else:
        isa = next(i for i, ok in isas if ok)
    return KernelInfo(
        name=kernel,
        isas=runnable,
        isa=isa,
        source=_FILES.get(kernel, "built-in"),
        citation=module.FILE_CITATION,
        **declared,
    )


def build_info() -> dict:
    """How the built-in kernels in use were built (the installed extension, or :func:`~tribench.ext.use_build`'s):
    compiler, flags, FMA and fast-math macros, and the resolution of the clock that times batches."""
    return dict(_MODULES[_KERNELS[0]].build_info())


def extension_sha256() -> str:
    """The sha256 of the compiled extension's file: which build of the C code this is."""
    return module_sha256(_core.__file__)


#: The sha256 of a compiled module's file (read once per process).
module_sha256 = functools.cache(file_sha256)


def use_module(module: ModuleType) -> None:
    """Take the built-in kernels from ``module``: a build of the extension's C files (``--builds``)."""
    if tuple(module.kernel_names(True)) != tuple(k for k in _KERNELS if k in BUILT_IN):
        raise UserError(f"{module.__name__} is not a build of this extension's kernels")
    for k in BUILT_IN:
        _MODULES[k] = module


def bytes_per_triangle(kernel: str, dtype: np.dtype | type | str) -> int:
    """Bytes of prepared data one triangle occupies for ``kernel`` at ``dtype``.

    >>> bytes_per_triangle("moller_trumbore", "float32")
    36
    """
    info, dt = kernel_info(kernel), check_dtype_name(dtype)
    if dt.name not in info.precisions:
        raise UserError(f"{kernel} is compiled for {', '.join(info.precisions)}, not {dt.name}")
    return info.bytes_per_triangle[dt.name]


def core_of(kernel: str) -> ModuleType:
    """The compiled module that holds ``kernel``: ``_core``, or the build of the kernel file that declared it."""
    return _MODULES[check_kernel(kernel)]


def kernel_modules() -> tuple[ModuleType, ...]:
    """The compiled modules kernels come from: ``_core`` first, then each kernel file's, in the order adopted."""
    return tuple(dict.fromkeys(_MODULES.values()))


def adopt(module: ModuleType, source: str) -> tuple[str, ...]:
    """Join a kernel file's compiled module to the registry: its kernels, public, after the others. A built-in
    kernel's name is refused; one adopted before is taken over (the same file compiled again after an edit, or
    its copy in a run folder; ext.load_kernels refuses another file's)."""
    global _PUBLIC, _KERNELS
    names = tuple(module.kernel_names(True))
    clashes = [k for k in names if k in BUILT_IN]
    if clashes:
        raise UserError(f"{', '.join(clashes)}: the name of a built-in kernel; give the kernel another name")
    for k in names:
        _MODULES[k] = module
        _FILES[k] = source
    _PUBLIC = (*_PUBLIC, *(k for k in names if k not in _PUBLIC))
    _KERNELS = (*_KERNELS, *(k for k in names if k not in _KERNELS))
    return names


def check_kernel(kernel: object) -> str:
    """A registered kernel's name (internal kernels too); an unknown one lists the public kernels."""
    if not isinstance(kernel, str):
        raise UserTypeError(f"kernel must be a str, got {type(kernel).__name__}")
    if kernel in _COMPILED and kernel not in _KERNELS:
        isas = ", ".join(i for i, _ in _core.kernel_info(kernel)["isas"])
        raise UserError(f"kernel {kernel!r} is compiled only for {isas}, which this CPU does not run")
    if kernel not in _KERNELS:
        raise UserError(f"unknown kernel {kernel!r}; known kernels: {', '.join(_PUBLIC)}")
    return kernel
