"""Pictures of workloads, so a person can see what a workload is (``workloads show --png``): a camera workload's
view beside a side view of its rays, a hit-rate workload's mesh with a sample of rays, a pair workload's crossings,
outcome counts and a few pairs in 3-D, each titled with its spec, targets and achieved figures."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..common import atomic_write
from .geometry import dot, normalise, triangle_normals
from .spec import MISS_STAGES, MeshSpec, PairSpec
from .workload import Workload

if TYPE_CHECKING:
    from .reference import PairAnswers

__all__ = ["draw"]

_HIT = "#2e9e44"
_MISS = "#d43d3d"
_AMBIGUOUS = "#111111"
_MESH = "#9aa4b1"
_OUTCOME_COLOURS = {
    "hit": _HIT,
    "parallel": "#8c564b",
    "behind_origin": "#9467bd",
    "outside_edge_1": "#ff7f0e",
    "outside_edge_2": "#1f77b4",
    "outside_edge_3": "#e377c2",
    "beyond_t_max": "#bcbd22",
    "other": "#7f7f7f",
}
_MAX_DRAWN_TRIANGLES = 25000


def draw(w: Workload, path: str | Path, dpi: float = 110) -> None:
    """Draw workload ``w`` into the PNG file ``path``. ``dpi`` sets the resolution only: the figures are 14 to 18
    inches wide, so 110 gives about 2000 pixels; the report passes less (it shows each about 550 wide)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if isinstance(w.spec, PairSpec):  # mode "pairs"
        fig = _draw_pairs(plt, w)
    elif w.spec.rays == "camera":
        fig = _draw_camera(plt, w)
    else:
        fig = _draw_hit_rate(plt, w)
    try:
        with atomic_write(path, "wb") as f:
            fig.savefig(f, dpi=dpi, format="png")
    finally:
        plt.close(fig)


def _pct(x: float) -> str:
    return f"{100 * x:.4g}%"


def _title(fig, w: Workload, line: str) -> None:
    fig.suptitle(f"{w.workload_id}: {w.spec.summary()}\n{line}", fontsize=10)


def _mesh_title(w: Workload) -> str:
    a, t = w.achieved, w.targets()
    tri = f"triangles: target {t['triangles']}, achieved {a['triangles']} ({a['count_method']})"
    ray = f"per-ray hit rate {_pct(a['ray_hit_rate'])}"
    if "ray_hit_rate" in t:
        ray = f"per-ray hit rate: target {_pct(t['ray_hit_rate'])}, achieved {_pct(a['ray_hit_rate'])}"
    return (
        f"{tri}\n{a['rays']} rays, {ray} ({a['ray_hits']} hits), "
        f"per-test hit rate {_pct(a['test_hit_rate'])}, {a['ambiguous_rays']} ambiguous rays"
    )


def _draw_mesh(ax, tri2d: np.ndarray, depth: np.ndarray | None = None) -> None:
    """Triangles projected to 2-D, light grey, far ones first (a painter's order)."""
    from matplotlib.collections import PolyCollection

    step = -(-len(tri2d) // _MAX_DRAWN_TRIANGLES)  # keep big meshes quick to draw
    if depth is not None:
        tri2d = tri2d[np.argsort(depth, kind="stable")]
    tri2d = tri2d[::step]
    ax.add_collection(PolyCollection(list(tri2d), facecolors="#dde2e8", edgecolors=_MESH, linewidths=0.3, zorder=1))


def _shading(w: Workload) -> np.ndarray:
    """Per-ray brightness of the surface hit: |cos| of the angle to the normal (0 for misses)."""
    assert w.ref_index is not None  # a mesh workload has closest hits
    hit = w.ref_index >= 0
    shade = np.zeros(len(hit))
    tri = w.triangles[w.ref_index[hit]].astype(np.float64)
    shade[hit] = np.abs(dot(normalise(triangle_normals(tri)), w.directions[hit].astype(np.float64)))
    return shade


def _draw_camera(plt, w: Workload):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    assert isinstance(w.spec, MeshSpec) and w.ref_index is not None  # a camera workload has closest hits
    width, height = w.spec.width, w.spec.height
    assert width is not None and height is not None  # MeshSpec set them
    hit = (w.ref_index >= 0).reshape(height, width)
    image = np.ones((height, width, 3))
    image[~hit] = (0.96, 0.80, 0.80)  # misses: pale red
    shade = _shading(w).reshape(height, width)
    green = np.array([0.18, 0.62, 0.27])
    image[hit] = (0.25 + 0.75 * shade[hit])[:, None] * green
    amb = w.ambiguous().reshape(height, width)

    fig, (left, right) = plt.subplots(
        1, 2, figsize=(14, 7.2), layout="constrained", gridspec_kw={"width_ratios": [1, 1.2]}
    )
    left.imshow(image, extent=(-1, 1, -1, 1), interpolation="nearest")
    jj, ii = np.nonzero(amb)
    left.scatter((2 * ii + 1 - width) / width, (height - 2 * jj - 1) / height, s=4, c=_AMBIGUOUS, marker="s", lw=0)
    left.set_title("what the camera sees: one ray per pixel centre (image plane z = 0)", fontsize=9)
    left.set_xlabel("x")
    left.set_ylabel("y")
    left.legend(
        handles=[
            Patch(color=tuple(green), label=f"hit ({int(hit.sum())}; shaded by surface angle)"),
            Patch(color=(0.96, 0.80, 0.80), label=f"miss ({int((~hit).sum())})"),
            Patch(color=_AMBIGUOUS, label=f"ambiguous: within 1e-5 or rounding of an edge ({int(amb.sum())})"),
        ],
        loc="lower left",
        fontsize=8,
    )

    # Side view: z across, y up; the eye, the image plane and a fan of rays in the x = 0 column.
    tri = w.triangles.astype(np.float64)
    _draw_mesh(right, tri[:, :, [2, 1]], depth=-tri[:, :, 0].mean(axis=1))
    eye = w.origins[0].astype(np.float64)
    column = width // 2
    rows = np.linspace(0, height - 1, min(height, 41)).astype(int)
    sample = rows * width + column
    for r in sample:
        d = w.directions[r].astype(np.float64)
        found = w.ref_index[r] >= 0
        t = w.ref_t[r] if found else 5.5
        end = eye + t * d
        right.plot([eye[2], end[2]], [eye[1], end[1]], color=_HIT if found else _MISS, lw=0.8, alpha=0.8, zorder=2)
        if found:
            right.plot(end[2], end[1], "o", color=_HIT, ms=3, zorder=3)
    right.plot([0, 0], [-1, 1], color="k", lw=2, zorder=2)
    right.annotate("image plane", (0, 1), xytext=(0.1, 1.15), fontsize=8)
    right.plot(eye[2], eye[1], "k^", ms=9, zorder=4)
    right.annotate("eye (0, 0, 2)", (eye[2], eye[1]), xytext=(eye[2] - 0.6, eye[1] + 0.25), fontsize=8)
    right.set_xlim(max(eye[2] + 0.4, 2.4), -4.0)  # the camera looks toward -z: draw it left to right
    right.set_ylim(-2.2, 2.2)
    right.set_aspect("equal")
    right.set_xlabel("z (camera looks toward -z)")
    right.set_ylabel("y")
    right.set_title("side view: mesh and the rays of the middle pixel column (x = 0)", fontsize=9)
    right.legend(
        handles=[
            Line2D([], [], color=_HIT, marker="o", ms=3, label="ray that hits (ends at the hit)"),
            Line2D([], [], color=_MISS, label="ray that misses"),
            Patch(facecolor="#dde2e8", edgecolor=_MESH, label=f"mesh ({len(tri)} triangles)"),
        ],
        loc="lower right",
        fontsize=8,
    )
    _title(fig, w, _mesh_title(w))
    return fig


def _draw_hit_rate(plt, w: Workload):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    tri = w.triangles.astype(np.float64)
    o = w.origins.astype(np.float64)
    d = w.directions.astype(np.float64)
    centre = np.array(w.achieved["bounding_sphere"]["centre"])
    radius = w.achieved["bounding_sphere"]["radius"]
    assert w.ref_index is not None  # a mesh workload has closest hits
    hit = w.ref_index >= 0
    sample = np.random.default_rng(0).choice(len(o), size=min(len(o), 40), replace=False)

    fig, axes = plt.subplots(1, 3, figsize=(18, 6.6), layout="constrained", gridspec_kw={"width_ratios": [1, 1, 0.9]})
    for ax, (a, b), view in zip(axes[:2], [(0, 1), (2, 1)], ["front view (x, y)", "side view (z, y)"], strict=True):
        away = 2 if a == 0 else 0  # the axis the view looks along
        _draw_mesh(ax, tri[:, :, [a, b]], depth=tri[:, :, away].mean(axis=1) * (1 if a == 0 else -1))
        ax.add_patch(plt.Circle((centre[a], centre[b]), radius, fill=False, ls="--", color="#555555", lw=0.8))
        for r in sample:
            t = w.ref_t[r] if hit[r] else 2.0 * np.linalg.norm(o[r] - centre)
            end = o[r] + t * d[r]
            if hit[r]:
                style = dict(color=_HIT, lw=1.0, alpha=0.9)
            else:
                style = dict(color=_MISS, lw=0.7, alpha=0.6, ls=(0, (4, 2)))
            ax.plot([o[r, a], end[a]], [o[r, b], end[b]], zorder=2, **style)
            ax.plot(o[r, a], o[r, b], "o", color=style["color"], ms=2.5, zorder=3)
            if hit[r]:
                ax.plot(end[a], end[b], "o", mfc="white", mec=_HIT, ms=4, zorder=3)
        span = 3.4 * radius
        ax.set_xlim(centre[a] - span, centre[a] + span)
        ax.set_ylim(centre[b] - span, centre[b] + span)
        ax.set_aspect("equal")
        ax.set_title(f"{view}: {len(sample)} of {len(o)} rays", fontsize=9)
        ax.set_xlabel("xyz"[a])
        ax.set_ylabel("xyz"[b])
    axes[0].legend(
        handles=[
            Line2D([], [], color=_HIT, marker="o", mfc="white", ms=4, label="hit ray, origin to hit point"),
            Line2D([], [], color=_MISS, ls=(0, (4, 2)), label="miss ray"),
            Line2D([], [], color="#555555", ls="--", label="bounding sphere"),
            Patch(facecolor="#dde2e8", edgecolor=_MESH, label=f"mesh ({len(tri)} triangles)"),
        ],
        loc="lower left",
        fontsize=8,
    )

    # How close each ray's line passes to the mesh centre: near misses run through the bounding sphere.
    ax = axes[2]
    w_c = centre - o
    along = np.einsum("ij,ij->i", w_c, d)
    closest = np.sqrt(np.maximum(np.einsum("ij,ij->i", w_c, w_c) - along * along, 0.0)) / radius
    bins = np.linspace(0, max(1.6, closest.max()), 41)
    ax.hist(
        [closest[hit], closest[~hit]],
        bins=bins,
        color=[_HIT, _MISS],
        stacked=True,
        label=[f"hits ({int(hit.sum())})", f"misses ({int((~hit).sum())})"],
    )
    ax.axvline(1.0, color="#555555", ls="--", lw=0.8)
    ax.annotate(
        "bounding sphere", (1.0, ax.get_ylim()[1] * 0.95), xytext=(4, 0), textcoords="offset points", fontsize=8
    )
    ax.set_xlabel("distance of the ray's line from the mesh centre / bounding radius")
    ax.set_ylabel("rays")
    ax.set_title("all rays: how close each passes to the mesh", fontsize=9)
    ax.legend(fontsize=8)
    _title(fig, w, _mesh_title(w))
    return fig


@dataclass(frozen=True)
class _PairSample:
    """The pairs a pair workload's picture draws: a sample, its reference answers and each one's outcome."""

    o: np.ndarray  # every pair's origin, direction and triangle, float64
    d: np.ndarray
    tri: np.ndarray
    sample: np.ndarray  # indices of the sampled pairs, ascending
    ans: PairAnswers  # the float64 reference's answers for the sample
    names: np.ndarray  # "hit", a miss stage or "other", per sampled pair


def _sample_pairs(w: Workload) -> _PairSample:
    """Up to 4000 pairs (the same for every draw), answered and classified by the float64 reference."""
    from .pairs import HIT, OTHER, classify_misses
    from .reference import intersect_pairs

    o = w.origins.astype(np.float64)
    d = w.directions.astype(np.float64)
    tri = w.triangles.astype(np.float64)
    rng = np.random.default_rng(0)
    sample = np.sort(rng.choice(len(o), size=min(len(o), 4000), replace=False))
    t_max = None if w.t_max is None else w.t_max[sample]
    ans = intersect_pairs(o[sample], d[sample], tri[sample], t_max=t_max)
    codes = classify_misses(o[sample], d[sample], tri[sample], t_max=t_max)
    names = np.array(["hit" if c == HIT else (MISS_STAGES[c] if c < OTHER else "other") for c in codes])
    return _PairSample(o, d, tri, sample, ans, names)


def _draw_crossings(ax, s: _PairSample) -> None:
    """Where each sampled ray crosses its triangle's plane, every triangle mapped onto one reference triangle."""
    # a point of barycentrics (w, u, v) goes to w A + u B + v C
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    ans, names = s.ans, s.names
    with np.errstate(invalid="ignore"):
        p = ans.w[:, None] * corners[0] + ans.u[:, None] * corners[1] + ans.v[:, None] * corners[2]
    for name in ["hit", *MISS_STAGES, "other"]:
        sel = (names == name) & np.isfinite(p[:, 0])
        if sel.any():
            behind = name == "behind_origin"  # crossings inside the triangle, but at t < 0
            ax.scatter(
                p[sel, 0],
                p[sel, 1],
                s=7 if behind else 4,
                c=_OUTCOME_COLOURS[name],
                marker="x" if behind else "o",
                lw=0.5 if behind else 0,
                alpha=0.6 if behind else 0.5,
                label=f"{name} ({int((names == name).sum())})",
                zorder=3 if behind else 2,
            )
    ax.fill(*np.vstack([corners, corners[:1]]).T, fc="none", ec="k", lw=1.5, zorder=3)
    for k, (v_a, v_b, where) in enumerate([(0, 1, (0.5, -0.08)), (1, 2, (0.83, 0.47)), (2, 0, (0.17, 0.47))]):
        ax.annotate(
            f"edge {k + 1}: v{v_a}->v{v_b}",
            where,
            ha="center",
            fontsize=8,
            zorder=4,
            rotation=[0, -60, 60][k],
            bbox=dict(fc="white", ec="none", alpha=0.7, pad=0.5),
        )
    for k, c in enumerate(corners):
        ax.annotate(f"v{k}", c, xytext=(c[0] + [-0.08, 0.03, -0.02][k], c[1] + [-0.05, -0.05, 0.04][k]), fontsize=9)
    ax.set_xlim(-1.2, 2.2)
    ax.set_ylim(-1.1, 2.1)
    ax.set_aspect("equal")
    n = len(s.sample)
    ax.set_title(
        f"where {n} sampled rays cross their triangle's plane\n"
        "(every triangle mapped onto one; parallel rays never cross)",
        fontsize=9,
    )
    ax.legend(loc="upper left", fontsize=7, markerscale=2, title=f"sample of {n}", title_fontsize=7)


def _draw_outcomes(ax, w: Workload) -> None:
    """Target against achieved counts per outcome (hit, then each miss stage), by the float64 reference."""
    from .pairs import apportion

    t, a = w.targets(), w.achieved
    misses = t["pairs"] - t["hits"]
    target_counts = [t["hits"], *apportion(list(t["miss_mix"].values()), misses)]
    achieved_counts = [a["hits"], *(a["miss_counts"].get(s, 0) for s in MISS_STAGES)]
    labels = ["hit", *MISS_STAGES]
    y = np.arange(len(labels))
    ax.barh(y - 0.2, target_counts, height=0.4, color="#cccccc", label="target")
    ax.barh(y + 0.2, achieved_counts, height=0.4, color=[_OUTCOME_COLOURS[n] for n in labels], label="achieved")
    for yi, c in zip(y, achieved_counts, strict=True):
        ax.annotate(str(c), (c, yi + 0.2), xytext=(3, -3), textcoords="offset points", fontsize=8)
    ax.set_yticks(y, labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("pairs")
    ax.set_title("outcomes: target (grey) vs achieved, by the float64 reference", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")


def _draw_sample_pairs(ax, w: Workload, s: _PairSample) -> None:
    """A few pairs in 3-D: the triangle and the ray up to its crossing (or a bit past)."""
    from matplotlib.lines import Line2D
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    assert isinstance(w.spec, PairSpec)
    o, d, tri, sample, names = s.o, s.d, s.tri, s.sample, s.names
    few = sample[:: max(1, len(sample) // 8)][:8]
    for i, j in zip(few, np.searchsorted(sample, few), strict=True):
        colour = _OUTCOME_COLOURS[names[j]]
        ax.add_collection3d(
            Poly3DCollection([tri[i]], facecolors=colour, edgecolors=colour, linewidths=0.8, alpha=0.35)
        )
        t_end = s.ans.t[j] if np.isfinite(s.ans.t[j]) and s.ans.t[j] > 0 else 3.0 * w.spec.scale
        end = o[i] + t_end * d[i]
        ax.plot(*np.stack([o[i], end]).T, color=colour, lw=1.2)
        ax.scatter(*o[i], color=colour, s=10)
    points = np.vstack([tri[few].reshape(-1, 3), o[few]])
    lo, hi = points.min(axis=0), points.max(axis=0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_title(f"{len(few)} sample pairs: triangle, ray origin (dot) and ray", fontsize=9)
    shown = sorted(set(names[np.searchsorted(sample, few)]))
    ax.legend(handles=[Line2D([], [], color=_OUTCOME_COLOURS[n], label=n) for n in shown], fontsize=7, loc="upper left")


def _pairs_line(w: Workload) -> str:
    """The title's second line: per-test hit rate and miss mix, target against achieved."""
    t, a = w.targets(), w.achieved
    mix = ", ".join(
        f"{s} {_pct(t['miss_mix'][s])}/{_pct(a['miss_mix'].get(s, 0))}"
        for s in MISS_STAGES
        if t["miss_mix"][s] or a["miss_counts"].get(s)
    )
    return (
        f"per-test hit rate: target {_pct(t['hit_rate'])}, achieved {_pct(a['hit_rate'])} "
        f"({a['hits']} of {a['pairs']}); miss mix target/achieved: {mix or 'no misses'}"
    )


def _draw_pairs(plt, w: Workload):
    """Three panels: where the sampled rays cross their planes, the outcome counts, a few pairs in 3-D."""
    assert isinstance(w.spec, PairSpec)
    s = _sample_pairs(w)
    fig = plt.figure(figsize=(17, 6.6), layout="constrained")
    grid = fig.add_gridspec(1, 3, width_ratios=[1.25, 1, 1])
    _draw_crossings(fig.add_subplot(grid[0]), s)
    _draw_outcomes(fig.add_subplot(grid[1]), w)
    _draw_sample_pairs(fig.add_subplot(grid[2], projection="3d"), w, s)
    _title(fig, w, _pairs_line(w))
    return fig
