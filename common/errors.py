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

__all__ = ["Notice", "UserError", "UserTypeError"]


class UserError(ValueError):
    """A mistake in what the user gave tribench; the message says what and how to fix it."""


class UserTypeError(UserError, TypeError):
    """A :class:`UserError` about the type of an argument."""


class Notice(UserWarning):
    """Something the user should know that stops nothing (a corrupt cache file rebuilt); printed as one line."""
