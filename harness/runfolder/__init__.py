"""The run folder: the only thing measuring hands to analysis and reporting.

:mod:`.schema` names every file and column once; :mod:`.io` writes, reads and
validates the measured files. Both are re-exported (``runfolder.BATCHES``)."""

from .io import *  # noqa: F403
from .io import __all__ as _io_all
from .schema import *  # noqa: F403
from .schema import __all__ as _schema_all

__all__ = [*_schema_all, *_io_all]
