"""Harness: measuring, and the run folder it writes.

The sweep plan (:mod:`.plan`, :mod:`.sweep_file`, :mod:`.stages`), the runner and its worker processes
(:mod:`.runner`, :mod:`.worker`, :mod:`.protocol`, :mod:`.layout`), the machine record, the FMA peak (:mod:`.peak`),
the A/A margin (:mod:`.margin`), the run folder (:mod:`.runfolder`); below them the statistics (:mod:`.stats`),
above them the jobs (:mod:`.jobs`). It may import ``common``, ``ext`` and ``workloads``; never ``reports`` or
``cli``."""
