"""Build a reduction in a fresh interpreter: the FE build of a process-pool worker.

netgen meshes OCC geometry with OpenCascade's thread pool (``OSD_ThreadPool``). A worker forked
from a process that has meshed inherits that pool's state without its threads, and its own
meshing then waits forever for them (measured: ``OSD_ThreadPool::EnumeratedThread::WaitIdle``
in the self-check's generator workers, each building a disc with a drawn modification
deviation after the parent had meshed the nominal disc). So a worker never meshes in its own
process: :func:`build_isolated` runs the build (:func:`rvflex.fe.hcb.build`) in a new Python
process (``python -m rvflex.fe.isolated``, which imports nothing of the caller), which writes
the reduction to the disk cache; the worker then loads it from there. The input goes to the
child pickled on its standard input (our own objects, from our own process).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile

from rvflex.choices import FEPart

__all__ = ["build_isolated"]


def build_isolated(spec, part: FEPart, settings, key: str, cache_dir: str | os.PathLike | None, use_cache: bool):
    """Reduce ``part`` of ``spec`` with ``settings`` (a :class:`~rvflex.fe.types.PartSettings`) in a
    new interpreter and return it from the disk cache (``cache_dir``; with ``use_cache`` False a
    temporary one, removed afterwards).

    Raises
    ------
    FEError
        The child process failed (its error, one line, is in the message).
    """
    from rvflex.fe import cache
    from rvflex.fe.types import FEError

    with tempfile.TemporaryDirectory(prefix="rvflex-fe-") as tmp:
        where = cache_dir if use_cache else tmp
        job = pickle.dumps({"spec": spec, "part": part, "settings": settings, "key": key,
                            "cache_dir": None if where is None else str(where)})
        proc = subprocess.run([sys.executable, "-m", "rvflex.fe.isolated"], input=job, capture_output=True,
                              check=False)
        rp = cache.load(key, where) if proc.returncode == 0 else None
        if rp is None:  # the child's last line says why (its one-line error, or a crash's last words)
            lines = [ln.strip() for ln in (proc.stderr or proc.stdout).decode(errors="replace").splitlines() if ln.strip()]
            raise FEError(f"the {part} reduction (built in a separate process, rc {proc.returncode}) did not reach "
                          f"the cache {cache.cache_root(where)}: {lines[-1] if lines else 'no output'}")
    rp.meta["cached"] = False
    return rp


def _main() -> int:
    from rvflex.fe import cache
    from rvflex.fe.hcb import build

    job = pickle.loads(sys.stdin.buffer.read())
    try:
        cache.store(build(job["spec"], job["part"], job["settings"], job["key"], None), job["cache_dir"])
    except Exception as err:  # noqa: BLE001 -- one line for the parent's FEError, not a traceback
        print(f"{type(err).__name__}: " + " ".join(str(err).split()), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(_main())
