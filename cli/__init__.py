"""The ``tribench`` command line, at the top of the import order.

``tribench.cli`` owns the console script (:func:`console`, ``python -m
tribench.cli``; :func:`main` runs one command in-process): :mod:`.command`
is the entry point and maps failures to exit codes; each subcommand is one module here (``info``, ``sweep``, ``stats``,
``calibrate``, ``run``, ``peers``, ``validate``, ``seed``, ``workloads``,
``report``, ``compare``, ``export``) with its flags beside its handler;
:mod:`.flags` checks one flag's text and :mod:`.options` adds the flags
several commands share. It only parses arguments and calls the library, so
it may import every other tribench package; none of them imports it.
"""

from .command import console, main

__all__ = ["console", "main"]
