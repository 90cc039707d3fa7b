"""The statistics moved to :mod:`tribench.stats`; this name keeps old imports working."""

from tribench.stats import *  # noqa: F403
from tribench.stats import __all__  # noqa: F401
