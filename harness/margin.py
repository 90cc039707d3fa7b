"""The equivalence margin a sweep uses: the latest A/A calibration's, or the default.

Apart from the calibration (:mod:`.jobs.calibrate`), which needs the runner,
so the imports stay one-way: runner -> margin, calibration -> runner."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..common import UserError
from ..common.location import cache_dir
from .stats import DEFAULTS, check_margin

__all__ = ["AA_TWINS", "CALIBRATION", "Margin", "latest_margin", "user_calibration_path"]

CALIBRATION = "calibration.json"

#: The kernels with an A/A twin (the same source compiled again under another
#: name, ext/kernels/*_aa.h): ``tribench calibrate`` times the first pair, and the
#: main job times its baseline's twin beside it (:mod:`tribench.reports.tables.margin`).
AA_TWINS = {"moller_trumbore": "moller_trumbore_aa", "moller_seed": "moller_seed_aa"}


_FIX = "run `tribench calibrate` again, or delete the file to use the default margin"


@dataclass(frozen=True)
class Margin:
    """An equivalence margin (relative, 0.01 = 1 %) and where it came from; checked to lie in ``[0, MAX_MARGIN]``."""

    value: float
    source: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", check_margin(self.value, f"margin of {self.source}"))


def user_calibration_path() -> Path:
    """The latest calibration of this user, next to the workload cache (``~/.cache/tribench/calibration.json``)."""
    return cache_dir().parent / CALIBRATION


def latest_margin(cpu_model: str | None = None) -> Margin:
    """The latest calibration's margin, if it was measured on ``cpu_model``; else the default.

    An unusable calibration file is a UserError naming the file and the key,
    before anything is measured: a silent fallback would pass for a calibrated margin.

    >>> m = latest_margin("no such cpu")
    >>> m.value == DEFAULTS.margin and m.source.startswith("default")
    True
    """
    path = user_calibration_path()
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return Margin(DEFAULTS.margin, "default (stats.DEFAULTS.margin: no calibration found)")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: cannot read the calibration file ({exc}); {_FIX}") from None
    try:
        cal = json.loads(text)
    except (ValueError, RecursionError):
        raise UserError(f"{path}: not a calibration file (not valid JSON); {_FIX}") from None
    if not isinstance(cal, dict) or "margin" not in cal:
        raise UserError(f"{path}: not a calibration file (no 'margin' key); {_FIX}")
    try:
        value = check_margin(cal["margin"], f"{path}: key 'margin'")
    except UserError as exc:
        raise UserError(f"{exc}; {_FIX}") from None
    if not isinstance(cal.get("cpu_model"), (str, type(None))):
        raise UserError(f"{path}: key 'cpu_model' must be a string, got {cal['cpu_model']!r:.40}; {_FIX}")
    if cpu_model is not None and cal.get("cpu_model") != cpu_model:
        other = str(cal.get("cpu_model"))[:200]
        return Margin(DEFAULTS.margin, f"default (stats.DEFAULTS.margin: {path} is for another CPU, {other})")
    created, run = str(cal.get("created", "?"))[:40], str(cal.get("run_dir", "?"))[:200]
    return Margin(value, f"calibration {path} ({created}, run {run})")
