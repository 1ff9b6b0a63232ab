"""Output that is never left half-written."""
import os
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "remove_temporaries", "interrupts_deferred",
           "TEMPORARY_PREFIX"]

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


#: the signals that stop a run as Ctrl-C does (a batch system's kill
#: sends SIGTERM)
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def interrupts_deferred(reraise: bool = True):
    """Hold Ctrl-C (SIGINT) and SIGTERM back while the block runs, so that
    what it writes is whole: either meanwhile is raised as
    ``KeyboardInterrupt`` when the block has ended (``reraise``), or
    dropped (a caller that is stopping anyway).  A ``KeyboardInterrupt``
    raised in the block itself passes as any exception does.  Outside the
    main thread the block runs as it is, and so it does for a signal with
    no Python handler (ignored, default, set from C).

    Examples
    --------
    >>> import os, signal
    >>> from skfem_mpm.scenes.io import interrupts_deferred
    >>> before = signal.signal(signal.SIGINT, signal.default_int_handler)
    >>> try:
    ...     with interrupts_deferred():
    ...         os.kill(os.getpid(), signal.SIGINT)
    ...         finished = True
    ... except KeyboardInterrupt:
    ...     print("interrupted after the block, finished:", finished)
    interrupted after the block, finished: True
    >>> _ = signal.signal(signal.SIGINT, before)

    (Python's own handler is set first, as it is where the process was
    started with Ctrl-C ignored, e.g. in the background of a script.)

    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    held = {signum: previous for signum, previous in held.items()
            if callable(previous)}
    received = []
    for signum in held:
        signal.signal(signum, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        for signum, previous in held.items():
            signal.signal(signum, previous)
    if received and reraise:
        raise KeyboardInterrupt


@contextmanager
def terminate_as_interrupt():
    """While the block runs (in the main thread), SIGTERM raises
    ``KeyboardInterrupt`` as Ctrl-C does, so that a run killed by a batch
    system keeps what converged and says so (a checkpoint and an
    interrupted ``summary.json``; before, it left neither summary nor the
    last steps' checkpoint)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


#: what a run writes in its output folder (globs): an earlier run's
#: files there are removed when a new run (not a resume) starts
RUN_OUTPUTS = ("points_*.vtu", "grid_*.vtu", "points.pvd", "grid.pvd",
               "checkpoint.npz", "summary.json", "deformed_shape.png",
               "final_stress.png",
               "final_von_mises.png", "plastic_zone.png",
               "column_stress.png", "load_displacement.png",
               "rigid_bodies.png", "obstacles.png", "contacts.png",
               "energies.png")


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
