"""``python -m tribench.cli``: the ``tribench`` command."""

from .command import console

console()
