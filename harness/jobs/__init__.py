"""Jobs: what tribench measures, each through the runner into a run folder.

:mod:`.sweep` is the one way a sweep runs; :mod:`.main` the main job
(``tribench run``), :mod:`.seed` the seed paper's replay, :mod:`.peers`
tribench against trimesh and Embree, :mod:`.calibrate` the A/A calibration,
:mod:`.validate` the robustness suite and :mod:`.kernel_check` a kernel file's
check. They measure and never analyse: the tables are
:mod:`tribench.reports.tables`'. They may import the rest of ``harness`` and
every package below it.
"""
