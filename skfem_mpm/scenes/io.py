"""Output that is never left half-written."""
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "remove_temporaries", "TEMPORARY_PREFIX"]

#: temporary files start so (hidden, and told apart from a user's files)
TEMPORARY_PREFIX = ".skfem-mpm-partial."


@contextmanager
def atomic_path(path):
    """Yield a temporary file name beside ``path``; rename it to ``path``
    only when the block completes, remove it otherwise.  The file gets the
    mode of any new file (``0o666`` less the umask: readable by the group
    and others as usual), not the owner-only mode of the temporary.

    Examples
    --------
    >>> import os, tempfile
    >>> from skfem_mpm.scenes.io import atomic_path
    >>> target = os.path.join(tempfile.mkdtemp(), "out.txt")
    >>> with atomic_path(target) as tmp:
    ...     _ = open(tmp, "w").write("done")
    >>> open(target).read()
    'done'

    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=TEMPORARY_PREFIX + path.stem + ".",
                               suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


#: what a run writes in its output folder (globs): an earlier run's
#: files there are removed when a new run (not a resume) starts
RUN_OUTPUTS = ("points_*.vtu", "grid_*.vtu", "points.pvd", "grid.pvd",
               "checkpoint.npz", "summary.json", "final_stress.png",
               "column_stress.png", "load_displacement.png",
               "rigid_bodies.png", "energies.png")


def clear_earlier_run(outdir) -> list:
    """Remove the files an earlier run wrote in ``outdir`` (the names of
    :data:`RUN_OUTPUTS`, nothing else); returns the names removed."""
    removed = sorted({p.name for pattern in RUN_OUTPUTS
                      for p in Path(outdir).glob(pattern) if p.is_file()})
    for name in removed:
        os.remove(Path(outdir) / name)
    return removed


def current_umask() -> int:
    """The process's umask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def remove_temporaries(outdir) -> int:
    """Remove the temporary files a killed run left in ``outdir`` (a kill
    skips the clean-up of :func:`atomic_path`); returns how many.  Not for
    a folder another run is writing to."""
    stale = list(Path(outdir).glob(TEMPORARY_PREFIX + "*"))
    for path in stale:
        path.unlink(missing_ok=True)
    return len(stale)
