"""A run's estimates and speedups in Google Benchmark's JSON format (``google_benchmark.json``; why and how:
docs/results.md, "Export: Google Benchmark JSON"). Each interval travels as extra numeric fields, as its user
counters do, and each process is one ``iteration`` entry, so ``compare.py`` can run its U test on two
exports. Strict JSON: an undefined interval is left out, never NaN."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from typing import Any

import pandas as pd

from ...harness import runfolder

__all__ = ["google_benchmark", "dumps", "JSON_SCHEMA_VERSION"]

#: The ``context.json_schema_version`` Google Benchmark's tools accept.
JSON_SCHEMA_VERSION = 1

_CACHE_TYPES = {"d": "Data", "i": "Instruction", "": "Unified"}
_SIZE_UNITS = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3}


def _caches(sizes: Mapping[str, str]) -> list[dict[str, Any]]:
    """``{'L1d': '48K', ...}`` (the machine record) as Google Benchmark's cache list; unreadable ones left out."""
    out = []
    for name, size in sizes.items():
        key = re.fullmatch(r"L(\d)([di]?)", name)
        value = re.fullmatch(r"(\d+)([KMG]?)", str(size).strip())
        if key and value:
            out.append(
                {
                    "type": _CACHE_TYPES[key.group(2)],
                    "level": int(key.group(1)),
                    "size": int(value.group(1)) * _SIZE_UNITS[value.group(2)],
                    "num_sharing": 0,  # not recorded
                }
            )
    return out


def _context(run: runfolder.Run, baseline: str, margin: Mapping[str, Any]) -> dict[str, Any]:
    machine = run.machine
    try:
        mhz = round(float(machine.get("cpu_mhz") or 0))
    except ValueError:  # not a number: unknown, as Google Benchmark writes an unknown clock
        mhz = 0
    context: dict[str, Any] = {
        "date": run.created,
        "host_name": "",  # tribench records no host name
        "executable": "tribench",
        "num_cpus": int(machine.get("logical_cpus") or 0),
        "mhz_per_cpu": mhz,
    }
    if machine.get("governor"):
        context["cpu_scaling_enabled"] = machine["governor"] != "performance"
    context |= {
        "caches": _caches(machine.get("caches") or {}),
        "load_avg": [float(x) for x in machine.get("load_average") or []],
        "library_version": f"tribench {machine.get('tribench', 'unknown')}",
        "library_build_type": "release",
        "json_schema_version": JSON_SCHEMA_VERSION,
        "run_id": run.run_id,
        "time_per": "ray-triangle test",
        "baseline": baseline,
        "margin": f"{margin.get('value')} ({margin.get('source')})",
    }
    for key, value in machine.items():
        context[f"machine.{key}"] = value if isinstance(value, str) else json.dumps(value, sort_keys=True)
    return context


def _finite(fields: Mapping[str, Any]) -> dict[str, float]:
    """The fields that are finite numbers, as floats (an undefined interval is left out)."""
    return {k: float(v) for k, v in fields.items() if v is not None and math.isfinite(float(v))}


def _entry(suffix: str, ids: tuple[str, int, int], label: str, **fields: Any) -> dict[str, Any]:
    """One benchmark entry of ``ids`` (its run name, family and instance), named its run name + ``suffix``."""
    run_name, family, instance = ids
    return {
        "name": run_name + suffix,
        "family_index": family,
        "per_family_instance_index": instance,
        "run_name": run_name,
        **fields,
        "time_unit": "ns",
        "label": label,
    }


def google_benchmark(
    run: runfolder.Run, tables: Mapping[str, pd.DataFrame], baseline: str, margin: Mapping[str, Any]
) -> dict[str, Any]:
    """A run's estimates, speedups and machine record as ``{"context": ..., "benchmarks": [...]}`` from ``tables``
    (by file name) and the verdicts' ``margin`` (``{"value", "source"}``), ready for ``allow_nan=False``."""
    keys = ["build", "kernel", "workload_id"]
    est = tables[runfolder.ESTIMATES]
    spd = tables[runfolder.SPEEDUPS].set_index(keys)
    pp = tables[runfolder.PER_PROCESS]
    builds = list(dict.fromkeys(est["build"]))
    kernels = [k for k in run.sweep.kernels if k in set(est["kernel"])]
    wids = [w for w in run.sweep.workload_ids if w in set(est["workload_id"])]
    rows = est.set_index(keys)
    benchmarks: list[dict[str, Any]] = []
    families = [(b, k) for b in builds for k in kernels]
    for family, instance, key in ((f, i, (*bk, w)) for f, bk in enumerate(families) for i, w in enumerate(wids)):
        if key not in rows.index:
            continue
        build, kernel, wid = key
        r = rows.loc[key]
        # a run of several builds names each benchmark's build too (its own processes)
        name, label = f"{kernel}/{wid}" + (f"/{build}" if len(builds) > 1 else ""), str(r["workload"])
        per = pp.loc[(pp["build"] == build) & (pp["kernel"] == kernel) & (pp["workload_id"] == wid)]
        per = per.sort_values("process")
        ids = (name, family, instance)
        benchmarks += _repetitions(ids, label, per) + _time_aggregates(ids, label, r, len(per))
        if key in spd.index and math.isfinite(spd.loc[key]["ratio"]):
            benchmarks.append(_speedup(ids, label, spd.loc[key], baseline, len(per)))
    return {"context": _context(run, baseline, margin), "benchmarks": benchmarks}


def _repetitions(ids: tuple[str, int, int], label: str, per: pd.DataFrame) -> list[dict[str, Any]]:
    """One ``iteration`` entry per worker process: its median ns per test (the replicate)."""
    return [
        _entry(
            "",
            ids,
            label,
            run_type="iteration",
            repetitions=len(per),
            threads=1,
            repetition_index=i,
            iterations=int(p.n_rounds),
            real_time=float(p.ns_per_test),
            cpu_time=float(p.ns_per_test),
            process=int(p.process),
        )
        for i, p in enumerate(per.itertuples(index=False))
    ]


def _aggregate(
    ids: tuple[str, int, int], label: str, n: int, name: str, unit: str, iterations: int, value: float, **fields: Any
) -> dict[str, Any]:
    """The ``_<name>`` aggregate entry of ``n`` processes: ``value`` as its real and CPU time, then ``fields``."""
    return _entry(
        f"_{name}",
        ids,
        label,
        run_type="aggregate",
        repetitions=n,
        threads=1,
        aggregate_name=name,
        aggregate_unit=unit,
        iterations=iterations,
        real_time=value,
        cpu_time=value,
        **fields,
    )


def _time_aggregates(ids: tuple[str, int, int], label: str, r: pd.Series, n: int) -> list[dict[str, Any]]:
    """The ``_mean`` entry (ns per test with its intervals) and, where finite, the ``_stddev`` entry."""
    interval = {k: r[f"ns_per_test_{k}"] for k in ("ci_low", "ci_high", "bootstrap_low", "bootstrap_high")}
    interval["confidence"] = r["confidence"]
    out = [_aggregate(ids, label, n, "mean", "time", n, float(r["ns_per_test"]), **_finite(interval))]
    if math.isfinite(r["ns_per_test_sd"]):
        out.append(_aggregate(ids, label, n, "stddev", "time", n, float(r["ns_per_test_sd"])))
    return out


def _speedup(ids: tuple[str, int, int], label: str, s: pd.Series, baseline: str, n: int) -> dict[str, Any]:
    """The ``_speedup`` entry: the ratio over the baseline with its simultaneous interval and verdict."""
    interval = {k: s[f"ratio_{k}"] for k in ("ci_low", "ci_high")}
    interval |= {k: s[k] for k in ("confidence", "p_holm", "margin")}
    label = f"{label}; {s['verdict']} against {baseline}"
    return _aggregate(
        ids, label, n, "speedup", "percentage", int(s["n_processes"]), float(s["ratio"]), **_finite(interval)
    )


def dumps(document: Mapping[str, Any]) -> str:
    """The export as strict JSON text (no NaN or Infinity), one field per line."""
    return json.dumps(document, indent=2, allow_nan=False) + "\n"
