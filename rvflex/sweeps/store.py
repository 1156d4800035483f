"""The SQLite store of a sweep: one file per sweep, the design digest and one row per finished point.

Every point is written as soon as it finishes, so a rerun of the same design resumes; a store
written by another design is refused.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

from rvflex.spec import SpecError
from rvflex.sweeps.designs import Design

__all__ = ["Store"]


class Store:
    """One SQLite file per sweep: the design digest and one row per finished point."""

    def __init__(self, path: Path, design: Design, n_points: int):
        path.parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(path, timeout=30.0)
        self.db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)")
        self.db.execute("CREATE TABLE IF NOT EXISTS points (id INTEGER PRIMARY KEY, point TEXT, result TEXT, "
                        "error TEXT)")
        row = self.db.execute("SELECT value FROM meta WHERE key = 'digest'").fetchone()
        if row is None:
            self.db.execute("INSERT INTO meta VALUES ('digest', ?), ('design', ?), ('points', ?)",
                            (design.digest, design.name, str(n_points)))
            self.db.commit()
        elif row[0] != design.digest:
            raise SpecError("store", str(path), f"was written by a different design (digest {row[0]}, this one "
                                                f"{design.digest}): use another --out or delete it")

    def done(self) -> dict[int, tuple[str | None, str | None]]:
        return {i: (r, e) for i, r, e in self.db.execute("SELECT id, result, error FROM points")}

    def write(self, index: int, point: dict, result: dict | None, error: str | None) -> None:
        self.db.execute("INSERT OR REPLACE INTO points VALUES (?, ?, ?, ?)",
                        (index, json.dumps(point), None if result is None else json.dumps(result), error))
        self.db.commit()
