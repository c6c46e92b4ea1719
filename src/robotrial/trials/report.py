"""A trial database as one self-contained HTML page: tables and embedded plots (layer 5).

Runs are grouped by kind and configuration. Each group gives its runs, successes,
errors, and the mean, min and max of the kind's main figure (navigation time, planning
time, trajectory error); each kind gets a plot of that figure per group, and the
pictures runs wrote (SLAM maps) are embedded, so the page can be mailed as it is.
"""

from __future__ import annotations

import base64
import html
import io
import json
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.trials.kinds import KINDS
from robotrial.trials.store import RunRecord, TrialStore, canonical


def figure_of(rec: RunRecord, name: str) -> float | None:
    """The run's figure at a dotted path ("ate.rmse"), None when it has none."""
    value: Any = rec.figures
    for part in name.split("."):
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def group_runs(records: list[RunRecord]) -> dict[tuple[str, str], list[RunRecord]]:
    """Runs by (kind, configuration as canonical JSON), in order of first appearance."""
    groups: dict[tuple[str, str], list[RunRecord]] = defaultdict(list)
    for r in records:
        groups[(r.spec.kind, canonical(r.spec.config))].append(r)
    return dict(groups)


def group_summary(kind: str, runs: list[RunRecord]) -> dict[str, Any]:
    """Counts and the main figure's mean, min and max over the runs that have it (for
    kinds with a pass mark, over the successful runs, as the papers' tables do)."""
    name = KINDS[kind].figure if kind in KINDS else ""
    pool = [r for r in runs if r.success] if any(r.success is not None for r in runs) else runs
    values = [v for v in (figure_of(r, name) for r in pool) if v is not None]
    return {
        "runs": len(runs),
        "successes": sum(bool(r.success) for r in runs),
        "errors": sum(r.error is not None for r in runs),
        "figure": name,
        "mean": float(np.mean(values)) if values else None,
        "min": float(np.min(values)) if values else None,
        "max": float(np.max(values)) if values else None,
        "wall_time": float(sum(r.wall_time for r in runs)),
        "restarted": sum(r.attempts > 1 for r in runs),
    }


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return base64.b64encode(buf.getvalue()).decode()


def _plot(kind: str, groups: list[tuple[str, list[RunRecord]]]) -> str | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = KINDS[kind].figure
    data, labels = [], []
    for config, runs in groups:
        values = [v for v in (figure_of(r, name) for r in runs) if v is not None]
        if values:
            data.append(values)
            labels.append(config_label(json.loads(config), kind))
    if not data:
        return None
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(data)), 3.5))
    ax.boxplot(data)
    ax.set_xticks(range(1, len(labels) + 1), labels, rotation=20, ha="right", fontsize=8)
    ax.set_ylabel(name)
    ax.set_title(f"{kind}: {name} per configuration")
    fig.tight_layout()
    out = _png(fig)
    plt.close(fig)
    return out


def config_label(config: dict[str, Any], kind: str) -> str:
    """The settings that differ from the kind's defaults, or 'defaults'."""
    defaults = KINDS[kind].defaults if kind in KINDS else {}
    parts = [f"{k}={v}" for k, v in config.items() if defaults.get(k) != v]
    return ", ".join(parts) or "defaults"


def _cell(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


def _image(path: str) -> str:
    p = Path(path)
    if not p.is_file():
        return f"<p>missing: {html.escape(path)}</p>"
    data = base64.b64encode(p.read_bytes()).decode()
    return f'<img alt="{html.escape(p.name)}" src="data:image/png;base64,{data}" width="360">'


def html_report(store: TrialStore, title: str = "robotrial trials") -> str:
    """The page for every run in `store`."""
    records = list(store.records())
    groups = group_runs(records)
    by_kind: dict[str, list[tuple[str, list[RunRecord]]]] = defaultdict(list)
    for (kind, config), runs in groups.items():
        by_kind[kind].append((config, runs))
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;margin:2em;max-width:70em}"
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
        "padding:.3em .6em;text-align:right}td:first-child{text-align:left}"
        ".bad{color:#b00}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{len(records)} runs from {html.escape(str(store.path))}.</p>",
    ]
    for kind, kgroups in by_kind.items():
        parts.append(f"<h2>{html.escape(kind)}</h2><table><tr><th>configuration</th>")
        heads = ["runs", "successes", "errors", "restarted", "figure", "mean", "min", "max"]
        parts.append("".join(f"<th>{h}</th>" for h in heads) + "<th>wall (s)</th></tr>")
        for config, runs in kgroups:
            s = group_summary(kind, runs)
            row = [config_label(json.loads(config), kind), *(s[h] for h in heads), s["wall_time"]]
            parts.append("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>")
        parts.append("</table>")
        plot = _plot(kind, kgroups) if kind in KINDS else None
        if plot:
            parts.append(f'<img alt="{kind} plot" src="data:image/png;base64,{plot}">')
        errors = [r for _, runs in kgroups for r in runs if r.error]
        if errors:
            parts.append("<h3>Errors</h3><ul>")
            for r in errors:
                label = html.escape(config_label(r.spec.config, kind))
                error = html.escape(r.error or "")
                parts.append(f"<li class='bad'>seed {r.spec.seed}, {label}: {error}</li>")
            parts.append("</ul>")
        pictures = [(r, p) for _, runs in kgroups for r in runs[:1] for p in r.files.values()]
        pictures = [(r, p) for r, p in pictures if p.endswith(".png")]
        if pictures:
            parts.append("<h3>Pictures</h3>")
            parts.extend(_image(p) for _, p in pictures)
    parts.append("</body></html>")
    return "\n".join(parts)
