"""The one user-error type of tribench, at the bottom of the import order.

A user's mistake -- an argument, a file, a command-line flag, the
environment (a full disk, a missing permission) -- raises :class:`UserError`
with a message that names the thing and, where there is one, the fix. The
``tribench`` command prints such an error as one line and exits 2; anything
else is a bug in tribench and keeps its traceback.

``UserError`` is a ``ValueError`` and :class:`UserTypeError` also a
``TypeError``, so code that caught the built-in types before still works.

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
    """Something the user should know that stops nothing (a corrupt cache file
    rebuilt, say); the ``tribench`` command prints it as one line."""
