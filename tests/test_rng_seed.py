"""An RNG seed is ``rng_seed`` since #52 ("seed" is the 2022 paper). What was written or typed with ``seed`` works
as before, and no workload id changes: old run folders and caches name their workloads by id."""

from __future__ import annotations

import pytest

from tribench.harness.plan import default_sweep
from tribench.workloads.spec import MeshSpec, PairSpec, SeedSpec, workload_id

#: Ids computed on main at 1229c95, before the rename: a spec's id hashes the same bytes as then.
PINNED = [
    (PairSpec(), "pairs-7a9fc0e82fdd"),
    (PairSpec(n=4096, hit_rate=0.25, dtype="float32", winding="facing", rng_seed=7), "pairs-175044538539"),
    (MeshSpec("suzanne", triangles=968, width=48, height=48, dtype="float32", rng_seed=3), "mesh-e683994e9073"),
    (MeshSpec("suzanne", triangles=250_000, width=64, height=64, dtype="float32", accel="bvh"), "mesh-245c8209589a"),
    (MeshSpec("icosphere", rays="hit_rate", n_rays=100, rng_seed=2**63 - 1), "mesh-dc094f916843"),
    (SeedSpec("scene02", rays="shadow", sample=64, width=16, height=16, rng_seed=5), "seed-8c926e57fd84"),
]
#: The main job's workloads (``tribench run``, then ``--quick``), on main at 1229c95.
MAIN_JOB_IDS = {
    False: "pairs-39828f93718b pairs-ba114ab2046d pairs-07fbfdc68d51 pairs-ad45fe15c12a pairs-cf0e0d9f0629 "
    "pairs-5c37d705b958 pairs-e3d340e11831 pairs-b7fdfadc2cad pairs-a143422bc56e pairs-a0efa0d9a042 "
    "mesh-7d83416c18fb mesh-03983f0384a6 mesh-245c8209589a",
    True: "pairs-1638dcfbab0d pairs-8b51930e7077 pairs-35801482fe70 mesh-d7f39a28fb7c mesh-03f6c283ae6e "
    "mesh-9729c15e5742",
}


@pytest.mark.parametrize(("spec", "wid"), PINNED, ids=[w for _, w in PINNED])
def test_workload_ids_are_those_before_the_rename(spec, wid):
    assert workload_id(spec) == wid


@pytest.mark.parametrize("quick", [False, True])
def test_the_main_jobs_workload_ids_are_those_before_the_rename(quick):
    assert " ".join(default_sweep(quick).workload_ids) == MAIN_JOB_IDS[quick]
