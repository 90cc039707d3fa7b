"""The human names of workloads: a family, a short label and a one-line text, from a spec dict."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any


def family_of(spec: Mapping[str, Any]) -> str:
    """The family a workload belongs to: its spec without the swept axis, hit rate for pairs (the hit-rate
    curves) and triangle count for meshes (the scaling curves).

    >>> family_of({"kind": "pairs", "n": 100, "hit_rate": 0.5, "order": "shuffled",
    ...            "shape": "sphere", "dtype": "float64", "rng_seed": 0, "scale": 1.0, "offset": 0.0})
    'pairs n=100 shuffled sphere float64'

    Pairs wound to face their rays are another family (a culling kernel does other work on the two):

    >>> family_of({"kind": "pairs", "n": 100, "hit_rate": 0.5, "order": "shuffled",
    ...            "shape": "sphere", "dtype": "float64", "winding": "facing"})
    'pairs n=100 shuffled sphere facing float64'
    >>> family_of({"kind": "mesh", "mesh": "suzanne", "triangles": 200, "rays": "camera",
    ...            "width": 64, "height": 64, "dtype": "float64", "rng_seed": 0})
    'mesh suzanne camera 64x64 float64'

    So is a BVH workload (its times per test are of another kind: a slope across both would mean nothing):

    >>> family_of({"kind": "mesh", "mesh": "suzanne", "triangles": 200, "rays": "camera",
    ...            "width": 64, "height": 64, "dtype": "float64", "rng_seed": 0, "accel": "bvh"})
    'mesh suzanne camera 64x64 bvh float64'
    """
    if spec.get("kind") == "pairs":
        extra = (
            ""
            if (spec.get("scale", 1.0), spec.get("offset", 0.0)) == (1.0, 0.0)
            else f" scale={spec['scale']:g} offset={spec['offset']:g}"
        )
        mix = spec.get("miss_mix")
        mix_text = ""
        if isinstance(mix, dict) and not _even_edges(mix):
            mix_text = " misses[" + ",".join(f"{k}={v:.2g}" for k, v in mix.items() if v) + "]"
        facing = " facing" if spec.get("winding") == "facing" else ""  # a random winding is left out of the spec
        return (
            f"pairs n={spec.get('n')} {spec.get('order', '')} {spec.get('shape', '')}{facing} "
            f"{spec.get('dtype', '')}{mix_text}{extra}"
        ).replace("  ", " ")
    mesh = Path(str(spec.get("mesh", "?"))).name
    if spec.get("rays") == "hit_rate":
        rays = f"{spec.get('n_rays')} rays per-ray hit rate {spec.get('hit_rate'):g}"
    elif spec.get("rays") == "bounce":
        rays = f"bounces of camera {spec.get('width')}x{spec.get('height')}"
    elif spec.get("rays_sha256"):
        rays = f"{spec.get('n_rays')} rays from {Path(str(spec.get('rays'))).name}"
    else:
        rays = f"camera {spec.get('width')}x{spec.get('height')}"
    accel = " bvh" if spec.get("accel") == "bvh" else ""
    return f"mesh {mesh} {rays}{accel} {spec.get('dtype', '')}"


def _even_edges(mix: Mapping[str, float]) -> bool:
    edges = [mix.get(f"outside_edge_{i}", 0.0) for i in (1, 2, 3)]
    return all(abs(e - 1 / 3) < 1e-6 for e in edges)


def short_label(spec: Mapping[str, Any]) -> str:
    """What varies inside a family, in words (for table rows and plot labels).

    >>> short_label({"kind": "pairs", "hit_rate": 0.5})
    'per-test hit rate 50%'
    >>> short_label({"kind": "mesh", "mesh": "suzanne", "triangles": None})
    'suzanne, base mesh'
    """
    if spec.get("kind") == "pairs":
        return f"per-test hit rate {100 * spec['hit_rate']:.4g}%"
    count = spec.get("triangles")
    mesh = Path(str(spec.get("mesh", "?"))).name
    return f"{mesh}, {count} triangles" if count else f"{mesh}, base mesh"


def spec_text(spec: Mapping[str, Any]) -> str:
    """The spec's own one-line summary (falls back to JSON for an unknown spec)."""
    try:
        from .kinds import spec_from_dict

        return spec_from_dict(dict(spec)).summary()
    except Exception:  # an old or foreign spec: still show something true
        return json.dumps(spec, sort_keys=True)
