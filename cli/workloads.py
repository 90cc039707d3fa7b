"""``tribench workloads``: make, list and show cached workloads (docs/commands.md).

Each leaf command stores its handler in ``func``; heavy modules are imported
inside the handlers only. Examples (tests/test_cli_examples.py runs them)::

    tribench workloads make pairs --n 10000 --hit-rate 0.3 --miss-mix uniform
    tribench workloads make suzanne --triangles 5000            # camera rays
    tribench workloads make icosphere --hit-rate 0.5 --n-rays 4096
    tribench workloads make suzanne --rays bounce --triangles 5000  # secondary rays
    tribench workloads make ~/meshes/bunny.ply --triangles 20000
    tribench workloads make suzanne --rays my_rays.npz            # your own rays
    tribench workloads list
    tribench workloads show mesh-3f2a --png suzanne.png"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..common import UserError
from ..workloads.pairs import SCALE_RANGE
from ..workloads.spec import ACCELS, ORDERS, RAY_SETS, SHAPES, WINDINGS
from . import flags
from .options import add_rng_seed, usage

__all__ = ["add_parser", "main", "parse_miss_mix"]

# The spec fields `make` has a flag for, with the flag's argparse options: the only attributes of the
# parsed arguments that go into a spec (the namespace also holds the command's own).
_PAIR_OPTIONS: dict[str, dict[str, Any]] = {
    "n": {"type": int, "help": "number of pairs (default 10000)"},
    "order": {"choices": ORDERS, "help": "default shuffled"},
    "miss_mix": {
        "metavar": "MIX",
        "help": "edges (default), uniform, one stage name, or stage=fraction,... over parallel, "
        "behind_origin, outside_edge_1, outside_edge_2, outside_edge_3",
    },
    "shape": {"choices": SHAPES, "help": "default sphere"},
    "scale": {
        "type": float,
        "help": "size of every pair (default 1): "
        + ", ".join(f"{lo:g} to {hi:g} in {dtype}" for dtype, (lo, hi) in SCALE_RANGE.items()),
    },
    "offset": {"type": float, "help": "distance moved from the origin (default 0)"},
    "winding": {
        "choices": WINDINGS,
        "help": "random (default: a ray meets a back face half the time) or facing (every ray meets a front face)",
    },
}
_MESH_OPTIONS: dict[str, dict[str, Any]] = {
    "triangles": {"type": int, "help": "exact triangle count (default: the base mesh)"},
    "rays": {
        "metavar": "SET|FILE.npz",
        "help": f"{', '.join(RAY_SETS)} (default camera; bounce: one cosine-distributed bounce from each camera hit, "
        "incoherent secondary rays), or your own rays: an .npz file of origins and directions, each (N, 3), "
        "and optionally t_max (N,) (docs/own-rays.md)",
    },
    "n_rays": {"type": int, "help": "rays at a per-ray hit rate (default 4096)"},
    "width": {"type": int, "help": "camera width in pixels (default 512)"},
    "height": {"type": int, "help": "camera height in pixels (default 512)"},
    "accel": {
        "choices": ACCELS,
        "help": "how kernels run it: every ray against every triangle (default brute) or through a BVH with the "
        "kernel as its leaf test (native kernels only); the rays and answers are the same",
    },
}
_SHARED_OPTIONS = ("hit_rate", "dtype", "rng_seed")


def parse_miss_mix(text: str) -> str | dict[str, float]:
    """A preset name, or ``stage=fraction`` items separated by commas.

    >>> parse_miss_mix("parallel=0.5,behind_origin=0.5")
    {'parallel': 0.5, 'behind_origin': 0.5}
    >>> parse_miss_mix("edges")
    'edges'
    """
    if "=" not in text:
        return text
    mix = {}
    for item in text.split(","):
        stage, sep, value = item.partition("=")
        if stage.strip() in mix:  # a dict would keep the last and the sum would blame the fractions
            raise UserError(f"--miss-mix names the stage {stage.strip()!r} twice in {text!r}: give each stage once")
        try:
            mix[stage.strip()] = float(value)
        except ValueError:
            raise UserError(f"bad miss-mix item {item!r}: expected stage=fraction") from None
    return mix


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``workloads`` command (``make``, ``list``, ``show``) to ``subparsers``."""
    parser = subparsers.add_parser(
        "workloads",
        help="make, list and show workloads (meshes, rays, reference answers)",
        description="Workloads are pure functions of a spec, cached by the spec's hash "
        "(directory: $TRIBENCH_CACHE, default ~/.cache/tribench/workloads).",
    )
    parser.set_defaults(func=lambda args: usage(parser))
    sub = parser.add_subparsers(title="commands", metavar="COMMAND")

    make = sub.add_parser(
        "make",
        help="make (or find in the cache) the workload of a spec",
        description="KIND is 'pairs' (N independent ray-triangle pairs at a per-test hit rate), "
        "a built-in mesh (suzanne, icosphere, uvsphere, soup, heightfield) or the path of a mesh "
        "file trimesh reads. Meshes get the seed's camera rays unless --hit-rate or --n-rays asks "
        "for rays at a per-ray hit rate, or --rays bounce for one diffuse bounce from each camera hit.",
    )
    make.add_argument("kind", metavar="KIND")
    for title, options in (("pairs", _PAIR_OPTIONS), ("meshes", _MESH_OPTIONS)):
        group = make.add_argument_group(title)
        for dest, kwargs in options.items():
            group.add_argument(f"--{dest.replace('_', '-')}", **kwargs)
    both = make.add_argument_group("both")
    both.add_argument("--hit-rate", type=float, help="per-test (pairs) or per-ray (meshes) hit rate, default 0.5")
    both.add_argument("--dtype", choices=("float64", "float32"), help="default float64")
    add_rng_seed(both, "the workload's random choices")
    both.add_argument("--json", action="store_true", help="print the spec and figures as JSON")
    make.set_defaults(func=_make)

    lister = sub.add_parser("list", help="list the cached workloads")
    lister.set_defaults(func=_list)

    show = sub.add_parser("show", help="targets vs achieved figures of a cached workload, and a picture")
    show.add_argument("workload_id", metavar="ID", help="a workload id, or a unique prefix of one")
    show.add_argument("--png", metavar="FILE", type=flags.output_file, help="draw the workload into FILE")
    show.add_argument("--json", action="store_true", help="print the spec and figures as JSON")
    show.set_defaults(func=_show)
    return parser


def _spec_from_args(args: argparse.Namespace):
    from ..workloads.spec import MeshSpec, PairSpec

    options = (*_PAIR_OPTIONS, *_MESH_OPTIONS, *_SHARED_OPTIONS)
    given = {k: getattr(args, k) for k in options if getattr(args, k) is not None}
    if "miss_mix" in given:  # parsed here, not by argparse, so a bad mix is a one-line error
        given["miss_mix"] = parse_miss_mix(given["miss_mix"])
    if args.kind == "pairs":
        wrong = sorted(set(given) & set(_MESH_OPTIONS))
        if wrong:
            raise UserError(f"--{wrong[0].replace('_', '-')} applies to meshes, not pairs")
        return PairSpec(**given)
    wrong = sorted(set(given) & set(_PAIR_OPTIONS))
    if wrong:
        raise UserError(f"--{wrong[0].replace('_', '-')} applies to pairs, not meshes")
    if "rays" not in given and ("hit_rate" in given or "n_rays" in given):
        given["rays"] = "hit_rate"  # asking for a hit rate means rays aimed at one
    return MeshSpec(args.kind, **given)


def _format(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return "(" + ", ".join(_format(v) for v in value) + ")"
    return str(value)


def _report(w, as_json: bool) -> None:
    if as_json:
        shown = {"workload_id": w.workload_id, "spec": w.spec.to_dict(), "targets": w.targets(), "achieved": w.achieved}
        print(json.dumps(shown, indent=2))
        return
    print(f"{w.workload_id}  {w.spec.summary()}")
    rows = [(name, _format(t), _format(a)) for name, t, a in w.compare()]
    width = max(len(r[0]) for r in rows)
    twidth = max(len("target"), *(len(r[1]) for r in rows))
    print(f"  {'figure':<{width}}  {'target':>{twidth}}  achieved")
    for name, t, a in rows:
        print(f"  {name:<{width}}  {t:>{twidth}}  {a}")
    hits, sum_t = w.expected_checksum()
    print(f"  expected checksum: {hits} hits, sum of t = {sum_t!r}")


def _make(args: argparse.Namespace) -> int:
    from ..workloads.cache import make

    _report(make(_spec_from_args(args)), args.json)
    return 0


def _list(args: argparse.Namespace) -> int:
    from ..workloads.cache import cache_dir, list_cached
    from ..workloads.kinds import spec_from_dict

    entries = list_cached()
    if not entries:
        print(f"no workloads cached in {cache_dir()}")
        return 0
    for e in entries:
        try:
            summary = spec_from_dict(e.spec or {}).summary()  # no spec: refused, shown as null
        except Exception:  # a spec this version cannot rebuild (moved mesh file, old field...)
            summary = json.dumps(e.spec)
        size = f"{e.size_bytes / 1e6:.1f} MB"
        status = f"  [{e.problem}]" if e.problem else ""
        print(f"{e.workload_id}  {size:>9}  {summary}{status}")
    return 0


def _show(args: argparse.Namespace) -> int:
    from ..workloads.cache import load, resolve_id

    w = load(resolve_id(args.workload_id))
    _report(w, args.json)
    if args.png:
        from ..workloads.picture import draw

        try:
            draw(w, args.png)
        except OSError as e:
            raise UserError(f"cannot write {args.png}: {e}") from None
        print(f"wrote {args.png}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run ``workloads`` alone (``python -m tribench.cli.workloads make pairs``), its errors as the command's."""
    from .command import main as command_main

    return command_main(["workloads", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
