"""``python -m tribench.cli``: the ``tribench`` command."""

import sys

from .command import main

sys.exit(main())
