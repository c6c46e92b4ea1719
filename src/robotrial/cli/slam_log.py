"""`robotrial slam --log FILE`: build a map from a real-robot CARMEN log, print the time
per scan and, given the data set's relation file, the relative-pose error of Kuemmerle
et al. (layer 5; the helper of cli/slam.py for logs)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from robotrial.console import console, print_json, print_table, progress


def output_stem(output: str) -> Path:
    """`-o map`, `-o map.yaml` and `-o map.pgm` all mean the stem `map`."""
    p = Path(output)
    return p.with_suffix("") if p.suffix.lower() in (".yaml", ".yml", ".pgm") else p


def run_log(args: argparse.Namespace, params: dict[str, str]) -> int:
    """Map a CARMEN log with `args.method`; write the map files; print the figures."""
    from robotrial.model.carmen import CarmenError
    from robotrial.slam.gmapping import OdometryRequired
    from robotrial.trials import carmen, slam

    try:
        drift = None
        if args.drift_odometry is not None:
            drift = carmen.OdometryDrift(seed=args.drift_odometry)
        rec, log = carmen.load_log(args.log, order=args.order, drift=drift)
        if args.relations:
            carmen.read_relations(args.relations)  # a bad file fails before the long run
    except (CarmenError, FileNotFoundError, ValueError) as exc:
        console.print(f"[red]robotrial slam: {exc}")
        return 2
    declared, why = carmen.declared_params(log, args.method)
    if declared and not args.json:
        told = ", ".join(f"{k}={v:g}" for k, v in declared.items() if k not in params)
        console.print(
            f"{Path(args.log).name}: {why}; {args.method} is run with "
            f"{told or 'your values'} (--param overrides)"
        )
    params = {**carmen.replay_params(args.method), **declared, **params}
    if log.skipped and not args.json:
        number, why = log.skipped[0]
        console.print(
            f"[yellow]{args.log}: skipped {len(log.skipped)} malformed line(s); "
            f"first: line {number}: {why}"
        )
    try:
        with progress(
            f"{args.method} over {Path(args.log).name}", len(rec.scans), not args.json
        ) as adv:
            run_ = slam.run_slam(args.method, rec, params, on_scan=lambda i: adv())
    except (OdometryRequired, ValueError) as exc:
        console.print(f"[red]robotrial slam: {exc}")
        return 2
    scores = carmen.relation_scores(run_, args.relations) if args.relations else None
    result: dict[str, Any] = {"method": args.method, "source": str(args.log)}
    result.update(carmen.summary(run_, scores))
    result["skipped_lines"] = len(log.skipped)
    result["declared_params"] = {k: v for k, v in declared.items() if params[k] == v}
    result["duration_s"] = rec.duration
    result["files"] = slam.write_outputs(run_, rec, None, output_stem(args.output))
    if args.json:
        print_json(result)
        return 0
    rows: list[tuple[str, Any]] = []
    for k, v in result.items():
        if isinstance(v, dict):
            rows.extend((f"{k}.{kk}", vv) for kk, vv in v.items())
        else:
            rows.append((k, v))
    print_table(f"robotrial slam: {args.method} over a CARMEN log", ["quantity", "value"], rows)
    return 0
