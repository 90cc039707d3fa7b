"""The derived tables: a run folder's measured files in, every table the report reads out.

:mod:`.pipeline` is the analysis step; the other modules each build one family of tables. It never measures. It may
import ``common``, ``ext``, ``workloads`` and ``harness`` (``harness.jobs`` included, for what a job declares)."""

from .pipeline import *  # noqa: F403
from .pipeline import __all__ as __all__
