"""Workloads: meshes and ray sets from frozen specs, with float64 reference answers.

``tribench.workloads`` never times anything.
"""

from .reference import PairAnswers, intersect_closest, intersect_pairs

__all__ = ["PairAnswers", "intersect_closest", "intersect_pairs"]
