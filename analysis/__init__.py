"""Analysis: a run folder's measured files in, every derived table out.

It reads what :mod:`tribench.harness` measured (the run folder,
:mod:`tribench.harness.runfolder`) and derives with :mod:`tribench.stats`:
:mod:`.pipeline` is the analysis step (estimates, speedups, then every table
of ``runfolder.DERIVED``), :mod:`.tables` the table builders, :mod:`.export`
Google Benchmark's JSON format. It never times anything. It may import
``common``, ``ext``, ``workloads``, ``stats`` and ``harness``.
"""

from .pipeline import *  # noqa: F403
from .pipeline import __all__ as __all__
