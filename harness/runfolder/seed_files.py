"""The seed replay's tables (``tribench seed``), beside the runner's and the analysis's: names and columns."""

from __future__ import annotations

__all__ = ["SEED", "SEED_FILES", "SEED_KINDS", "SEED_PICTURES", "SEED_WORKLOADS"]

SEED = "seed.csv"
SEED_KINDS = "seed_kinds.csv"
SEED_WORKLOADS = "seed_workloads.csv"
SEED_PICTURES = "seed_pictures.csv"

MISS_STAGES = ("parallel", "behind_origin", "outside_edge_1", "outside_edge_2", "outside_edge_3")

#: The CSVs of a seed run (``tribench seed``), beside the runner's and the analysis's: file -> {column: meaning}.
SEED_FILES: dict[str, dict[str, str]] = {
    SEED: {
        "scene": "scene name (file stem for a scene file)",
        "kernel": "kernel name",
        "triangles": "triangles of the scene",
        "render_tests": "ray-triangle tests of one render (all ray kinds; shadow rays stop at the first occluder)",
        "render_s": "replayed time of one render's triangle tests, seconds: mean over processes",
        "render_s_ci_low": "lower end of its 95% Student-t interval over processes on the log scale, seconds",
        "render_s_ci_high": "upper end of that interval, seconds",
        "render_s_min": "smallest per-process value, seconds",
        "replay_ns_per_test": "render_s / render_tests, nanoseconds",
        "ratio_baseline": "the kernel the ratio divides by: moller_seed_object for the two object forms (the seed's "
        "program, Curless over Moller), moller_seed for the others",
        "ratio_to_moller_seed": "render time of this kernel / that of ratio_baseline (geometric mean of per-process "
        "ratios)",
        "ratio_to_moller_seed_ci_low": "lower end of its 95% paired interval",
        "ratio_to_moller_seed_ci_high": "upper end of that interval",
        "predicted_s_low": "object forms: the seed's own program's user time predicted on this machine, low end "
        "(the 95% interval widened by the replay's model error, harness/jobs/seed.py MODEL_ERROR), seconds",
        "predicted_s_high": "high end of that prediction, seconds",
        "predicted_ratio_low": "object forms: the program's Curless / Moller ratio predicted, low end (the ratio's "
        "interval widened by the model error)",
        "predicted_ratio_high": "high end of that prediction",
        "n_processes": "processes (replicates) behind the estimate",
        "paper_real_s": "the seed's Unix time 'real' for this kernel and scene, seconds (empty: not in the paper)",
        "paper_user_s": "the seed's Unix time 'user', seconds",
        "paper_ratio_real": "paper_real_s / moller_seed's paper_real_s",
        "paper_ratio_user": "paper_user_s / moller_seed's paper_user_s",
        "paper_user_ns_per_test": "paper_user_s / render_tests, nanoseconds: an upper bound on the seed's cost per "
        "test (its user time also covers spheres, the floor and shading)",
    },
    SEED_KINDS: {
        "scene": "scene name (file stem for a scene file)",
        "rays": "ray kind: primary, reflected or shadow",
        "kernel": "kernel name",
        "workload_id": "the sample's workload id (tribench workloads show ID)",
        "mode": "closest (primary, reflected) or any (shadow)",
        "ns_per_test": "nanoseconds per ray-triangle test the kernel ran: mean over processes of the per-process "
        "median",
        "ns_per_test_ci_low": "lower end of its 95% Student-t interval",
        "ns_per_test_ci_high": "upper end of that interval",
        "tests_per_pass": "tests the kernel runs in one pass over the sample (any mode: up to each ray's first "
        "hit, in blocks of 16 for native kernels)",
        "sample_tests": "tests a scalar kernel runs in one pass over the sample",
        "stream_tests": "tests a scalar kernel runs on all of the render's rays of this kind",
        "render_s": "this kind's share of render_s, seconds (mean over processes)",
        "render_share": "render_s / the render's render_s",
        "n_processes": "processes behind the estimate",
    },
    SEED_WORKLOADS: {
        "scene": "scene name (file stem for a scene file)",
        "rays": "ray kind, or 'render' for the three together (weighted by the render's tests)",
        "workload_id": "workload id (empty for 'render')",
        "mode": "closest or any",
        "triangles": "triangles of the scene",
        "stream_rays": "rays of this kind in the render that test the triangles",
        "stream_tests": "their ray-triangle tests",
        "sample_rays": "rays in the sample",
        "sample_tests": "tests of one pass over the sample",
        "test_hit_rate": "per-test hit rate: hits / tests run, by the float64 reference (fraction)",
        "ray_hit_rate": "per-ray hit rate: rays that hit a triangle / rays (fraction)",
        "ambiguous_rays": "sampled rays a finite-precision kernel may answer either way",
        **{f"miss_{s}": f"fraction of the misses rejected at stage {s} of Curless's test" for s in MISS_STAGES},
    },
    SEED_PICTURES: {
        "scene": "scene name (file stem for a scene file)",
        "width": "image width, pixels",
        "height": "image height, pixels",
        "dtype": "precision of the triangle tests",
        "differing_pixels": "pixels whose 8-bit colours differ between curless_seed and moller_seed",
        "near_edge_pixels": "of those, pixels with a ray passing within edge_tolerance of a triangle's boundary",
        "last_bit_pixels": "of the others, pixels whose colours differ by less than 1e-5 (a truncation flipped)",
        "other_pixels": "differing pixels explained by neither",
        "edge_tolerance": "barycentric tolerance of near_edge_pixels",
        "curless_seed_png": "the curless_seed render",
        "moller_seed_png": "the moller_seed render",
        "difference_png": "the differing pixels in red over the moller_seed render",
    },
}
