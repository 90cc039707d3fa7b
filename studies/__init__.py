"""Studies: the experiments tribench runs, each a plan for the harness's workers plus what it adds.

:mod:`.main` is the main job (``tribench run``), :mod:`.seed` the seed
paper's replay, :mod:`.peers` tribench against trimesh and Embree,
:mod:`.calibrate` the A/A calibration and :mod:`.validate` the robustness
suite. They may import every package below them, up to ``analysis``; only
``reports``, ``cli`` and the notebook facade import them.
"""
