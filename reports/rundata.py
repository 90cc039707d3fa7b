"""Everything the report needs from one run folder, read once.

The report reads files only: ``run.json``, ``batches.csv``, ``processes.csv``
and the tables ``estimates.csv``/``speedups.csv``. When those two are missing,
older than ``batches.csv`` (after a resume) or not in today's columns (written
by an older tribench), they are made by the harness's own analysis
(:func:`tribench.harness.analysis.analyse`) and written next to the batches:
the report never measures and never computes an interval itself. Likewise
``validate.csv``, the robustness table (:func:`load_validation`), is made by
the harness's suite (:func:`tribench.harness.validate.run`) when missing.
``peers.csv`` (:func:`load_peers`) is read when there; a missing one is never
measured here, since timing belongs to ``tribench run`` and ``tribench peers``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from tribench.common import UserError

__all__ = ["RunData", "RunError", "load_run", "load_validation", "load_peers", "PeerTables", "family_of", "short_label",
           "VALIDATE"]

#: The robustness table in a run folder (columns: ``columns.VALIDATE``).
VALIDATE = "validate.csv"


class RunError(UserError):
    """A run folder the report cannot use (one line saying why)."""


@dataclass
class RunData:
    """One run folder, read."""

    run_dir: Path
    run: dict[str, Any]
    batches: pd.DataFrame
    processes: pd.DataFrame
    estimates: pd.DataFrame
    speedups: pd.DataFrame
    baseline: str
    margin: float
    margin_source: str
    #: workload id -> spec dict, in sweep order
    specs: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: True when estimates/speedups were computed by this call
    analysed_now: bool = False

    @property
    def kernels(self) -> list[str]:
        """Kernels of the run that have timed batches, in sweep order."""
        present = set(self.batches["kernel"])
        return [k for k in self.run["sweep"]["kernels"] if k in present]

    @property
    def workload_ids(self) -> list[str]:
        present = set(self.batches["workload_id"])
        return [w for w in self.specs if w in present]

    @property
    def dtypes(self) -> list[str]:
        """Precisions of the run's batches, float32 first."""
        return sorted(set(self.batches["dtype"]))

    @property
    def n_processes(self) -> int:
        timed = self.batches.loc[~self.batches["warmup"]]
        return int(timed["process"].nunique())

    @property
    def machine(self) -> dict[str, Any]:
        return self.run.get("machine", {})


def load_run(run_dir: str | Path, baseline: str | None = None) -> RunData:
    """Read a run folder; make its tables with the harness's analysis if missing.

    Raises
    ------
    RunError
        The folder does not exist, or lacks ``run.json``/``batches.csv``, or
        they cannot be read, or there is nothing timed in it yet.
    """
    from tribench.harness import analysis, records

    from . import columns

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunError(f"no run directory {run_dir}")
    try:
        run = records.read_run(run_dir)
        batches = records.read_batches(run_dir, run)
        processes = records.read_processes(run_dir, run)
    except records.MissingRunFile as exc:
        raise RunError(f"{exc} (was the sweep started?)") from None
    except UserError as exc:  # the records' validation: file:line and what is wrong
        raise RunError(str(exc)) from None
    if batches.loc[~batches["warmup"]].empty:
        raise RunError(f"{run_dir} has no timed batches yet")

    est_path, spd_path = run_dir / analysis.ESTIMATES, run_dir / analysis.SPEEDUPS
    batches_mtime = (run_dir / "batches.csv").stat().st_mtime
    timed = batches.loc[~batches["warmup"]]
    pairs = set(zip(timed["kernel"], timed["workload_id"]))
    estimates = _usable_table(est_path, columns.FILES[est_path.name], batches_mtime, pairs, exact=True)
    speedups = _usable_table(spd_path, columns.FILES[spd_path.name], batches_mtime, pairs, exact=False)
    analysed_now = False
    if baseline is not None or estimates is None or speedups is None:
        try:
            result = analysis.analyse(run_dir, baseline=baseline)
        except UserError:
            raise
        except (ValueError, KeyError) as exc:
            raise RunError(f"cannot analyse {run_dir}: {exc}") from None
        analysis.write_tables(run_dir, result)
        estimates, speedups = pd.read_csv(est_path), pd.read_csv(spd_path)  # as the files have them
        analysed_now = True
    if speedups.empty:
        kernels = [k for k in run["sweep"]["kernels"] if k in set(batches["kernel"])]
        base = baseline or (analysis.DEFAULT_BASELINE if analysis.DEFAULT_BASELINE in kernels else kernels[0])
    else:
        base = str(speedups["baseline"].iloc[0])
    margin = run.get("margin", {})
    m_value = float(speedups["margin"].iloc[0]) if not speedups.empty else float(margin.get("value", 0.01))
    m_source = (str(speedups["margin_source"].iloc[0]) if "margin_source" in speedups and not speedups.empty
                else str(margin.get("source", "unknown")))
    specs = dict(zip(run["sweep"]["workload_ids"], run["sweep"]["workloads"]))
    return RunData(run_dir, run, batches, processes, estimates, speedups, base, m_value, m_source,
                   specs, analysed_now)


def load_validation(data: RunData, quick: bool = False) -> tuple[pd.DataFrame, str]:
    """The robustness table of the run's kernels and precisions, and a sentence saying where it came from.

    ``RUN_DIR/validate.csv`` when it is there in today's columns (``tribench run`` writes it);
    else the suite runs now (full sizes unless ``quick``) and its table is written there, so
    later reports reuse it. Rows of other kernels or precisions are left out, rows are in the
    run's kernel order. The suite must never stop a report: when it cannot run, the frame is
    empty and the sentence says why.
    """
    from tribench import ext
    from tribench.harness import records, validate

    from . import columns

    path = data.run_dir / VALIDATE
    if path.is_file() and _has_columns(path, columns.VALIDATE):
        df = pd.read_csv(path)
        note = f"Read from {VALIDATE} in the run folder."
    else:
        # an older run may name kernels this build no longer has: validate the others
        known = [k for k in data.kernels if k in ext.kernel_names(internal=True)]
        try:
            if not known:
                raise UserError("none of the run's kernels is in this build of the extension")
            df = validate.run(known, data.dtypes, quick=quick)
        except Exception as exc:
            return (pd.DataFrame(columns=list(columns.VALIDATE)),
                    f"The robustness suite could not run: {type(exc).__name__}: {exc}")
        note = (f"Computed now by tribench.harness.validate ({df.attrs['size']} sizes, seed {df.attrs['seed']}, "
                f"{df.attrs['seconds']:.1f} s)")
        try:
            records.write_csv(df, path)
            note += f" and written to {VALIDATE} in the run folder, which later reports read."
        except (OSError, UserError) as exc:  # a full disk or a read-only folder: show it all the same
            note += f"; not saved ({exc})."
    missing = [f"{k} {d}" for k in data.kernels for d in data.dtypes
               if not ((df["kernel"] == k) & (df["dtype"] == d)).any()]
    if missing:
        note += f" Not in the table: {', '.join(missing)}."
    order = {k: i for i, k in enumerate(data.kernels)}
    df = df.loc[df["kernel"].isin(order) & df["dtype"].isin(data.dtypes)]
    return df.sort_values("kernel", key=lambda s: s.map(order), kind="stable").reset_index(drop=True), note


@dataclass
class PeerTables:
    """A run's ``peers.csv`` and its figures (:func:`tribench.harness.peers.summarise`)."""

    frame: pd.DataFrame
    rates: pd.DataFrame
    ratios: pd.DataFrame

    @property
    def kernel(self) -> str:
        return str(self.frame["kernel"].iloc[0])

    @property
    def workload(self) -> str:
        return str(self.frame["workload"].iloc[0])


def load_peers(data: RunData) -> tuple[PeerTables | None, str]:
    """The run's peers (rows and figures) and a sentence on where they came from.

    None, with the reason, when ``peers.csv`` is absent, unreadable, in other
    columns or without usable rows: the report then says how to add them.
    """
    from tribench.harness import peers

    from . import columns

    path = data.run_dir / peers.PEERS
    how = (f"`{peers.INSTALL}` (embreex and rtree), then `tribench peers --out {data.run_dir}` and "
           f"`tribench report {data.run_dir}` add them")
    if not path.is_file():
        return None, f"No peers were measured with this run (no {peers.PEERS}): {how}."
    try:
        if not _has_columns(path, columns.PEERS):
            return None, f"{peers.PEERS} is not in today's columns (an older tribench wrote it): {how}."
        frame = pd.read_csv(path)
        rates, ratios = peers.summarise(frame)
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, ValueError, KeyError, IndexError) as exc:
        return None, f"{peers.PEERS} cannot be used ({type(exc).__name__}: {exc}): {how}."
    return PeerTables(frame, rates, ratios), f"Read from {peers.PEERS} in the run folder."


def _has_columns(path: Path, documented: dict[str, str]) -> bool:
    """True if the CSV's header is exactly the documented columns."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline(65536).rstrip("\r\n").split(",") == list(documented)
    except (OSError, UnicodeDecodeError):
        return False


#: The text columns of estimates.csv and speedups.csv; every other column is a number.
_TEXT_COLUMNS = {"kernel", "workload_id", "workload", "baseline", "verdict", "margin_source"}


def _usable_table(path: Path, documented: dict[str, str], batches_mtime: float, pairs: set[tuple[str, str]],
                  exact: bool) -> pd.DataFrame | None:
    """``estimates.csv`` or ``speedups.csv`` if it can stand for the batches as they are; None to re-analyse.

    Usable: a plain file newer than ``batches.csv``, in today's columns,
    numbers where numbers belong, and rows of the batches' own kernels and
    workloads (all of them when ``exact``). An edited, cut or older table is
    made again from the batches rather than shown.
    """
    try:
        if not (path.is_file() and not path.is_symlink() and path.stat().st_mtime >= batches_mtime
                and _has_columns(path, documented)):
            return None
        frame = pd.read_csv(path)
    except (OSError, UnicodeDecodeError, ValueError, pd.errors.ParserError):
        return None
    if any(not pd.api.types.is_numeric_dtype(frame[c]) for c in frame.columns if c not in _TEXT_COLUMNS):
        return None
    rows = set(zip(frame["kernel"].astype(str), frame["workload_id"].astype(str)))
    return frame if (rows == pairs if exact else rows <= pairs) else None


# ------------------------------------------------------------ workload labels


def family_of(spec: dict[str, Any]) -> str:
    """The family a workload belongs to: its spec without the swept axis.

    Pair workloads that differ only in hit rate form one family (the hit-rate
    curves); mesh workloads that differ only in triangle count form another
    (the scaling curves).

    Examples
    --------
    >>> family_of({"kind": "pairs", "n": 100, "hit_rate": 0.5, "order": "shuffled",
    ...            "shape": "sphere", "dtype": "float64", "seed": 0, "scale": 1.0, "offset": 0.0})
    'pairs n=100 shuffled sphere float64'
    >>> family_of({"kind": "mesh", "mesh": "suzanne", "triangles": 200, "rays": "camera",
    ...            "width": 64, "height": 64, "dtype": "float64", "seed": 0})
    'mesh suzanne camera 64x64 float64'
    """
    if spec.get("kind") == "pairs":
        extra = "" if (spec.get("scale", 1.0), spec.get("offset", 0.0)) == (1.0, 0.0) else \
            f" scale={spec['scale']:g} offset={spec['offset']:g}"
        mix = spec.get("miss_mix")
        mix_text = ""
        if isinstance(mix, dict) and not _even_edges(mix):
            mix_text = " misses[" + ",".join(f"{k}={v:.2g}" for k, v in mix.items() if v) + "]"
        return (f"pairs n={spec.get('n')} {spec.get('order', '')} {spec.get('shape', '')} "
                f"{spec.get('dtype', '')}{mix_text}{extra}").replace("  ", " ")
    mesh = Path(str(spec.get("mesh", "?"))).name
    if spec.get("rays") == "hit_rate":
        rays = f"{spec.get('n_rays')} rays per-ray hit rate {spec.get('hit_rate'):g}"
    else:
        rays = f"camera {spec.get('width')}x{spec.get('height')}"
    return f"mesh {mesh} {rays} {spec.get('dtype', '')}"


def _even_edges(mix: dict[str, float]) -> bool:
    edges = [mix.get(f"outside_edge_{i}", 0.0) for i in (1, 2, 3)]
    return all(abs(e - 1 / 3) < 1e-6 for e in edges)


def short_label(spec: dict[str, Any]) -> str:
    """What varies inside a family, in words (for table rows and plot labels).

    Examples
    --------
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


def spec_text(spec: dict[str, Any]) -> str:
    """The spec's own one-line summary (falls back to JSON for an unknown spec)."""
    try:
        from tribench.workloads.kinds import spec_from_dict

        return spec_from_dict(spec).summary()
    except Exception:  # an old or foreign spec: still show something true
        return json.dumps(spec, sort_keys=True)
