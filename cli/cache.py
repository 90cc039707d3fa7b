"""``tribench cache``: list every file of the cache, and prune what no installed build can use (docs/commands.md)."""

from __future__ import annotations

import argparse
import sys
import time

from .options import usage

__all__ = ["add_parser"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``cache`` command (``list``, ``prune``) to ``subparsers``."""
    parser = subparsers.add_parser(
        "cache",
        help="list the cache (workloads, BVH trees, front-face references, mesh copies) and prune it",
        description="The cache folder is $TRIBENCH_CACHE, default ~/.cache/tribench/workloads.",
    )
    parser.set_defaults(func=lambda args: usage(parser))
    sub = parser.add_subparsers(title="commands", metavar="COMMAND")
    lister = sub.add_parser("list", help="every cached file with its size, last use and whether it can be used")
    lister.set_defaults(func=_list)
    pruner = sub.add_parser(
        "prune",
        help="remove the files no installed build can use (BVH trees of another build, corrupt or stale files)",
    )
    pruner.add_argument(
        "--max-size",
        metavar="SIZE",
        help="then remove workloads, BVH trees and front-face references, oldest-used first, until the cache "
        "holds at most SIZE (500MB, 2GB, 0)",
    )
    pruner.add_argument("--dry-run", action="store_true", help="say what would be removed, remove nothing")
    pruner.set_defaults(func=_prune)
    return parser


def _mb(n: int) -> str:
    return f"{n / 1e6:.1f} MB"


def _line(e, root) -> str:
    used = time.strftime("%Y-%m-%d %H:%M", time.localtime(e.used))
    status = f"  [{e.problem}]" if e.problem else ""
    return f"{e.kind:<9}  {_mb(e.size_bytes):>9}  used {used}  {e.path.relative_to(root)}{status}"


def _list(args: argparse.Namespace) -> int:
    from ..common.location import cache_dir
    from ..workloads.cache_admin import entries

    found = entries()
    if not found:
        print(f"nothing cached in {cache_dir()}")
        return 0
    for e in found:
        print(_line(e, cache_dir()))
    unusable = [e for e in found if e.problem]
    total = sum(e.size_bytes for e in found)
    note = f", {len(unusable)} unusable ({_mb(sum(e.size_bytes for e in unusable))}: tribench cache prune)"
    print(f"{len(found)} files, {_mb(total)} in {cache_dir()}" + (note if unusable else ""))
    return 0


def _prune(args: argparse.Namespace) -> int:
    from ..common.location import cache_dir
    from ..workloads.cache_admin import parse_size, prune

    max_bytes = None if args.max_size is None else parse_size(args.max_size)
    done = prune(max_bytes, dry_run=args.dry_run)
    verb = "would remove" if args.dry_run else "removed"
    for e in done.removed:
        why = e.problem or "used longest ago"
        print(f"{verb} {e.path.relative_to(cache_dir())} ({_mb(e.size_bytes)}): {why}")
    freed = sum(e.size_bytes for e in done.removed)
    print(f"{verb} {len(done.removed)} files ({_mb(freed)}); {_mb(done.kept_bytes)} left in {cache_dir()}")
    if max_bytes is not None and done.kept_bytes > max_bytes:
        print(
            f"tribench cache: {_mb(done.kept_bytes)} is still over --max-size: the rest are mesh copies "
            "or files tribench did not write",
            file=sys.stderr,
        )
    return 0
