"""Harness: measuring, and the run folder it writes.

``tribench.harness`` owns the timing: the sweep plan (:mod:`.plan`), the sweep files (:mod:`.sweep_file`), its
sequential stages (:mod:`.stages`), the runner and its worker processes
(:mod:`.runner`, :mod:`.worker`), the duration estimate, the machine record,
the FMA peak and port model (:mod:`.peak`), the A/A margin (:mod:`.margin`),
and the run folder's schema, rows, I/O and lock (:mod:`.runfolder`).
It may import ``common``, ``ext``, ``workloads`` and ``stats``; never
``analysis``, ``studies``, ``reports`` or ``cli``.
"""
