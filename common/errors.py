"""The user-error types; the rule they follow (one line, exit 2; anything else is a bug) is docs/input.md's.

``UserError`` is a ``ValueError`` and :class:`UserTypeError` a ``TypeError`` too, so code that caught the
built-in types still works.

>>> try:
...     raise UserError("--rounds must be at least 1, got 0")
... except ValueError as exc:
...     print(exc)
--rounds must be at least 1, got 0
"""

from __future__ import annotations

import math
import os

__all__ = ["Notice", "UserError", "UserTypeError", "seconds_from_env"]


class UserError(ValueError):
    """A mistake in what the user gave tribench; the message says what and how to fix it."""


class UserTypeError(UserError, TypeError):
    """A :class:`UserError` about the type of an argument."""


class Notice(UserWarning):
    """Something the user should know that stops nothing (a corrupt cache file rebuilt); printed as one line."""


def seconds_from_env(variable: str, default: float, what: str) -> float:
    """``$variable`` as seconds (``what`` they are, for the error), else ``default``: a number >= 0."""
    text = os.environ.get(variable, "").strip()
    if not text:
        return default
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not 0 <= seconds < math.inf:
        raise UserError(f"{variable}={text!r}: expected {what}, a number >= 0")
    return seconds
