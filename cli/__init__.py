"""The ``tribench`` command line, at the top of the import order.

:mod:`.command` is the console script's entry point; each subcommand is one module here, its flags beside its
handler; :mod:`.flags` checks a flag's text and :mod:`.options` adds the flags several commands share. It only
parses arguments and calls the library, so it may import every other tribench package; none of them imports it."""

from .command import console, main

__all__ = ["console", "main"]
