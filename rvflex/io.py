"""Output plumbing shared by every writer: atomic file writes and the JSON/``--out`` emit of a
command.

A file is written to a unique temporary name in its destination folder and renamed over the
target (``os.replace``), so a reader sees the old file or the complete new one, never half of
one, and a failed run leaves no partial output.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
from pathlib import Path

__all__ = ["emit", "save_figure", "write_atomic", "write_json", "write_text"]


def write_atomic(path: str | os.PathLike, data: bytes, *, fsync: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (parents created; mode 0644); returns the path.

    ``fsync``: flush the data to the disk before the rename (caches that other processes read)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            if fsync:
                fh.flush()
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; results are ordinary files
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_json(path: str | os.PathLike, doc, **dumps_kwargs) -> Path:
    """Write ``doc`` as indented JSON (2 spaces; ``dumps_kwargs`` go to :func:`json.dumps`) atomically."""
    return write_atomic(path, json.dumps(doc, indent=2, **dumps_kwargs).encode())


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return write_atomic(path, text.encode("utf-8"))


def save_figure(fig, path: str | os.PathLike, **savefig_kwargs) -> Path:
    """Render a matplotlib figure (format from the suffix, default PNG) and write it atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix[1:] or "png", **savefig_kwargs)
    return write_atomic(path, buf.getvalue())


def emit(args, doc: dict, write_outputs) -> int:
    """Write a command's ``--out`` files and its ``--json`` document; returns the exit status 0.

    ``args`` has ``out`` and ``json`` (paths or None, e.g. an argparse namespace);
    ``write_outputs(dir) -> paths`` writes the files into ``--out`` and returns their paths,
    each printed as ``wrote PATH``.
    """
    if args.out:
        for path in write_outputs(Path(args.out)):
            print(f"wrote {path}")
    if args.json:
        write_json(Path(args.json), doc)
    return 0
