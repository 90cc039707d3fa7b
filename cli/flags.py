"""One check per kind of command-line flag, shared by every command that has it.

Each function is an argparse ``type=`` callable: the value, or an :class:`argparse.ArgumentTypeError` saying what is
wrong and what is wanted, before the command does anything. A value is never replaced silently: an empty list, a
zero count or a folder that is a file is refused, not defaulted.

>>> positive_int("12")
12
>>> float_list(0, 1)("0, 0.5,1")
[0.0, 0.5, 1.0]
>>> camera("64x48")
(64, 48)
>>> try:
...     positive_int("0")
... except argparse.ArgumentTypeError as exc:
...     print(exc)
must be an integer from 1 to 1000000000000, got '0'
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

__all__ = [
    "MAX_COUNT",
    "Parser",
    "MAX_RNG_SEED",
    "camera",
    "choice_list",
    "cpu",
    "existing_file",
    "existing_folder",
    "float_in",
    "float_list",
    "int_in",
    "int_list",
    "name_list",
    "output_file",
    "output_folder",
    "positive_int",
    "rng_seed",
]

T = TypeVar("T")

#: Larger counts are typos (and an int this big still fits every C and NumPy type).
MAX_COUNT = 10**12
#: The RNG seeds of the specs and the plan are non-negative int64.
MAX_RNG_SEED = 2**63 - 1
#: A camera side; a camera's rays are further bounded by the workload specs.
MAX_SIDE = 65536


class _StoreOnce(argparse._StoreAction):
    """argparse's store, refusing a second value: ``--kernels a --kernels b`` would keep b alone, silently (so
    would ``--rng-seed 1 --seed 2``, two names of one flag)."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = namespace.__dict__.setdefault(_GIVEN, {})
        if option_string is not None and self.dest in given:
            first = given[self.dest]
            again = "given more than once: give it once (a list takes commas: a,b)"
            raise argparse.ArgumentError(
                self, again if first == option_string else f"the same flag as {first}: give one"
            )
        given[self.dest] = option_string
        super().__call__(parser, namespace, values, option_string)


_GIVEN = "_flags_given"  # the namespace's record of the stores made, dropped before the command sees it


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose usage error is one line ending with where the usage is, and which refuses an
    option given twice; sub-parsers inherit it."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    def parse_known_args(self, args=None, namespace=None):
        parsed, extras = super().parse_known_args(args, namespace)
        parsed.__dict__.pop(_GIVEN, None)
        return parsed, extras

    def error(self, message: str):  # argparse's hook; never returns
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


_refuse = argparse.ArgumentTypeError

# Numbers on the command line are plain ASCII decimals: Python's int() and float()
# also take "1_000", other scripts' digits and control characters as spaces.
_INT = re.compile(r"[ \t]*[+-]?[0-9]+[ \t]*")
_FLOAT = re.compile(r"[ \t]*[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?[ \t]*")


def _decimal_int(text: str) -> int | None:
    return int(text) if _INT.fullmatch(text) else None


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An integer from ``lo`` to ``hi`` (a decimal literal; ``1e3`` and ``2.0`` are refused)."""

    def check(text: str) -> int:
        value = _decimal_int(text)
        if value is None or not lo <= value <= hi:
            raise _refuse(f"must be an integer from {lo} to {hi}, got {text!r}")
        return value

    check.__name__ = f"integer from {lo} to {hi}"
    return check


positive_int = int_in(1, MAX_COUNT)
rng_seed = int_in(0, MAX_RNG_SEED)


def float_in(lo: float, hi: float) -> Callable[[str], float]:
    """A finite number in ``[lo, hi]``; NaN and infinities are refused."""
    interval = f"[{lo:g}, {hi:g}]"

    def check(text: str) -> float:
        value = float(text) if _FLOAT.fullmatch(text) else math.nan
        if not (math.isfinite(value) and lo <= value <= hi):
            raise _refuse(f"must be a number in {interval}, got {text!r}")
        return value

    check.__name__ = f"number in {interval}"
    return check


def name_list(text: str) -> list[str]:
    """Comma-separated non-empty names (kernels, meshes), each once; what they name is checked where they are used."""
    items = [item.strip() for item in text.split(",")]
    if not any(items):
        raise _refuse(f"must be a non-empty comma-separated list, got {text!r}")
    if not all(items):
        raise _refuse(f"has an empty item in {text!r}")
    twice = sorted({x for x in items if items.count(x) > 1})
    if twice:  # it would run (or validate) the same thing twice and count it twice
        raise _refuse(f"names {', '.join(twice)} more than once in {text!r}")
    return items


def _list_of(item: Callable[[str], T]) -> Callable[[str], list[T]]:
    def check(text: str) -> list[T]:
        values = []
        for part in name_list(text):
            try:
                values.append(item(part))
            except argparse.ArgumentTypeError as exc:
                raise exc if part == text.strip() else _refuse(f"{exc} (in {text!r})") from None
        return values

    check.__name__ = "list"
    return check


def int_list(lo: int, hi: int) -> Callable[[str], list[int]]:
    """Comma-separated integers, each from ``lo`` to ``hi``."""
    return _list_of(int_in(lo, hi))


def float_list(lo: float, hi: float) -> Callable[[str], list[float]]:
    """Comma-separated finite numbers, each in ``[lo, hi]``."""
    return _list_of(float_in(lo, hi))


def choice_list(choices: Sequence[str]) -> Callable[[str], list[str]]:
    """Comma-separated items, each one of ``choices``."""

    def one(text: str) -> str:
        if text not in choices:
            raise _refuse(f"must be one of {', '.join(choices)}")
        return text

    return _list_of(one)


def builds(text: str) -> list[str]:
    """Build specs separated by ``;``, each a compiler and its flags (``gcc -O2;clang -O3``)."""
    from ..ext import BuildError, parse_builds

    try:
        specs = list(parse_builds(text))
    except BuildError as exc:
        raise _refuse(str(exc)) from None
    if not specs:
        raise _refuse("no build: give a compiler and its flags, such as 'gcc -O2;gcc -O3'")
    return specs


def camera(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT``, each side from 1 to 65536."""
    width, sep, height = text.strip().lower().partition("x")
    side = int_in(1, MAX_SIDE)
    try:
        if not sep:
            raise _refuse("")
        return side(width), side(height)
    except argparse.ArgumentTypeError:
        raise _refuse(f"must be WIDTHxHEIGHT with sides from 1 to {MAX_SIDE}, e.g. 64x64, got {text!r}") from None


def cpu(text: str) -> int:
    """One of the CPUs this process may run on (``os.sched_getaffinity(0)``)."""
    usable = sorted(os.sched_getaffinity(0))
    value = _decimal_int(text)
    if value not in usable:
        raise _refuse(f"{text!r} is not one of this process's CPUs {usable}")
    return value


# ------------------------------------------------------------------ paths


def _path(text: str) -> Path:
    if not text.strip():
        raise _refuse("must be a path, got an empty string")
    if "\0" in text:
        raise _refuse(f"must be a path, got {text!r} (a NUL byte)")
    return Path(text).expanduser()


def _check_can_create(path: Path) -> None:
    """Every existing ancestor of ``path`` is a folder, and the nearest one is writable."""
    for folder in path.absolute().parents:
        if folder.exists():
            if not folder.is_dir():
                raise _refuse(f"cannot be created in {str(folder)!r}: it is a file, not a folder")
            if not os.access(folder, os.W_OK | os.X_OK):
                raise _refuse(f"cannot be created in {str(folder)!r}: no permission to write there")
            return


def existing_file(text: str) -> str:
    """A file that exists (not a folder)."""
    path = _path(text)
    if path.is_dir():
        raise _refuse(f"must be a file, got the folder {text!r}")
    if path.exists() and not path.is_file():  # a device, a pipe, a socket
        raise _refuse(f"must be a regular file, got {text!r}")
    if not path.is_file():
        raise _refuse(f"no such file: {text!r}")
    return str(path)


def existing_folder(text: str) -> str:
    """A folder that exists: a run directory to read or resume."""
    path = _path(text)
    if path.exists() and not path.is_dir():
        raise _refuse(f"must be a folder, got the file {text!r}")
    if not path.is_dir():
        raise _refuse(f"no run directory {text!r}")
    return str(path)


def output_folder(text: str) -> str:
    """A folder to write into: it exists, or can be created."""
    path = _path(text)
    if path.exists():
        if not path.is_dir():
            raise _refuse(f"must be a folder, got the file {text!r}")
        if not os.access(path, os.W_OK | os.X_OK):
            raise _refuse(f"no permission to write in {text!r}")
    else:
        _check_can_create(path)
    return str(path)


def output_file(text: str) -> str:
    """A file to write: not a folder, in a folder that exists or can be created, and never a file the
    runner measured (a run folder's ``batches.csv``: writing over it would lose the run)."""
    from ..harness.runfolder import MEASURED, RUN

    path = _path(text)
    if path.is_dir():
        raise _refuse(f"must be a file, got the folder {text!r}")
    if path.name in MEASURED and (path.parent / RUN).is_file():
        raise _refuse(f"{text!r} is a measured file of the run folder {str(path.parent)!r}: write elsewhere")
    if path.exists():
        if not os.access(path, os.W_OK) or not os.access(path.parent, os.W_OK | os.X_OK):
            raise _refuse(f"no permission to write {text!r}")
    else:
        _check_can_create(path)
    return str(path)
