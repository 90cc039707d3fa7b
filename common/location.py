"""Where the cache lives: one function, below every module that reads or writes it."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir"]


def cache_dir() -> Path:
    """The cache directory, ``$TRIBENCH_CACHE`` or ``~/.cache/tribench/workloads`` (not created here)."""
    return Path(os.environ.get("TRIBENCH_CACHE") or "~/.cache/tribench/workloads").expanduser()
