"""The ``tribench`` command line, at the top of the import order.

``tribench.cli`` owns the console script (:func:`main`, ``python -m
tribench.cli``), its subcommands and the checks of their flags
(:mod:`.flags`): :mod:`.command` holds the harness's commands (``info``,
``sweep``, ``run``, ``seed``, ``peers``, ``stats``, ``calibrate``,
``validate``), :mod:`.workloads` the ``workloads`` command and
:mod:`.reports` ``report`` and ``compare``. It only parses arguments and
calls the library, so it may import every other tribench package; none of
them imports it.
"""

from .command import main

__all__ = ["main"]
