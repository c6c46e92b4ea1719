"""The trial database: one SQLite row per finished run (layer 5).

A run is named by its key: the trial kind, its configuration and its seed. A row is
written once, when the run ends (with its outcome or the error that stopped it), in
its own transaction, so an interrupted sweep keeps every run that finished and a
resumed sweep skips exactly those. Writing the same key twice is refused by the table,
so no run is ever recorded twice.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    key TEXT PRIMARY KEY,
    sweep TEXT NOT NULL,
    kind TEXT NOT NULL,
    config TEXT NOT NULL,
    seed INTEGER NOT NULL,
    success INTEGER,
    error TEXT,
    figures TEXT NOT NULL,
    files TEXT NOT NULL,
    worker TEXT NOT NULL,
    attempts INTEGER NOT NULL,
    wall_time REAL NOT NULL,
    finished REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_sweep ON runs (sweep);
"""


def canonical(config: dict[str, Any]) -> str:
    """The configuration as JSON with sorted keys: equal configurations, equal text."""
    return json.dumps(config, sort_keys=True, separators=(",", ":"))


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: the trial kind, its configuration and the seed."""

    kind: str
    config: dict[str, Any]
    seed: int

    @property
    def key(self) -> str:
        text = f"{self.kind}|{canonical(self.config)}|{self.seed}"
        return hashlib.sha1(text.encode()).hexdigest()[:20]


@dataclass
class RunRecord:
    """A finished run as stored: its spec, whether it succeeded, the error that stopped
    it (None when it ran to the end), its figures, the files it wrote, where it ran, how
    many times it was started (more than one when a worker died under it) and how long
    the last attempt took (wall seconds)."""

    spec: RunSpec
    sweep: str
    success: bool | None
    error: str | None
    figures: dict[str, Any]
    files: dict[str, str]
    worker: str
    attempts: int
    wall_time: float
    finished: float = 0.0


class TrialStore:
    """The runs of one or more sweeps in an SQLite file."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if self.path.exists() and self.path.is_dir():
            raise ValueError(f"trial database {self.path} is a folder, not a file")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self._db = sqlite3.connect(self.path)
            self._db.executescript(SCHEMA)
        except sqlite3.DatabaseError as exc:
            raise ValueError(f"trial database {self.path}: not an SQLite file ({exc})") from exc

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> TrialStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def done_keys(self, keys: list[str]) -> set[str]:
        """Which of these keys already have a row."""
        found: set[str] = set()
        for i in range(0, len(keys), 500):
            chunk = keys[i : i + 500]
            marks = ",".join("?" * len(chunk))
            rows = self._db.execute(f"SELECT key FROM runs WHERE key IN ({marks})", chunk)
            found.update(r[0] for r in rows)
        return found

    def add(self, rec: RunRecord) -> bool:
        """Store a finished run; False (and nothing written) when its key is already in."""
        s = rec.spec
        try:
            with self._db:
                self._db.execute(
                    "INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        s.key,
                        rec.sweep,
                        s.kind,
                        canonical(s.config),
                        s.seed,
                        None if rec.success is None else int(rec.success),
                        rec.error,
                        json.dumps(rec.figures),
                        json.dumps(rec.files),
                        rec.worker,
                        rec.attempts,
                        rec.wall_time,
                        rec.finished or time.time(),
                    ),
                )
        except sqlite3.IntegrityError:
            return False
        return True

    def records(self, sweep: str | None = None) -> Iterator[RunRecord]:
        """Every stored run (of one sweep), in the order they finished."""
        query = (
            "SELECT sweep, kind, config, seed, success, error, figures, files, worker, "
            "attempts, wall_time, finished FROM runs"
        )
        args: tuple = ()
        if sweep is not None:
            query += " WHERE sweep = ?"
            args = (sweep,)
        for row in self._db.execute(query + " ORDER BY finished", args):
            yield RunRecord(
                RunSpec(row[1], json.loads(row[2]), row[3]),
                row[0],
                None if row[4] is None else bool(row[4]),
                row[5],
                json.loads(row[6]),
                json.loads(row[7]),
                row[8],
                row[9],
                row[10],
                row[11],
            )

    def count(self) -> int:
        return int(self._db.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
