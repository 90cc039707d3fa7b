"""The run folder: the only thing measuring hands to analysis and reporting.

:mod:`.schema` names every file and every CSV's columns, once; :mod:`.io`
builds the measured files' rows from that schema, appends them, reads and
validates them, and holds the one writer's lock. Both are re-exported here,
so a caller writes ``runfolder.BATCHES`` and ``runfolder.read_batches``.
"""

from . import io as io
from . import schema as schema
from .io import *  # noqa: F403
from .io import __all__ as _io_all
from .schema import *  # noqa: F403
from .schema import __all__ as _schema_all

__all__ = [*_schema_all, *_io_all]
