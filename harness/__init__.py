"""Harness: timed sweeps and the run folder they write.

``tribench.harness`` owns measuring: the sweep plan, worker processes, the
run folder's records, the analysis step that turns batches into tables with
:mod:`tribench.stats` (and into Google Benchmark's JSON format,
:mod:`.export`), the A/A margin and calibration, validation, the seed
replay and the peers. It may import ``common``, ``ext``, ``workloads`` and
``stats``; never ``reports`` or ``cli``. (``tribench.harness.stats`` is
:mod:`tribench.stats` under its old name.)
"""
