"""Warnings said once over runs repeated in one call.

A call that runs a problem again and again (the trials of
:func:`~skfem_mpm.solve.strength_reduction.strength_reduction`) heard
each run's warnings once per run: a user trial's B-spline slope said the
same points-per-cell warning 8 times.  :func:`warnings_once` lets each
warning's text through once, for the loggers of this package.

>>> import logging
>>> from skfem_mpm.repeats import warnings_once
>>> log = logging.getLogger("skfem_mpm.example")
>>> with warnings_once() as once:
...     for _ in range(3):
...         log.warning("the same words")
>>> once.dropped
2
"""
import logging
from contextlib import contextmanager

__all__ = ["OnceEach", "warnings_once"]


class OnceEach(logging.Filter):
    """Passes each warning (and error) text once, every record below
    ``WARNING``; counts those it drops.  While ``hushed`` (set it), it
    drops every warning not said before and counts it in
    ``hushed_count`` too (the trials after the first of a strength
    reduction)."""

    def __init__(self):
        super().__init__()
        self.seen, self.dropped, self.loggers = set(), 0, []
        self.hushed, self.hushed_count = False, 0

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING:
            return True
        text = record.getMessage()
        if text in self.seen:
            self.dropped += 1
            return False
        if self.hushed:
            self.dropped += 1
            self.hushed_count += 1
            return False
        self.seen.add(text)
        return True

    def cover(self, prefix: str = "skfem_mpm"):
        """Filter the package's loggers, those made since too (a logger's
        filters see only its own records, not its children's)."""
        manager = logging.getLogger().manager
        names = [prefix] + [name for name in list(manager.loggerDict)
                            if name.startswith(prefix + ".")]
        for name in names:
            log = logging.getLogger(name)
            if log not in self.loggers:
                log.addFilter(self)
                self.loggers.append(log)


@contextmanager
def warnings_once(prefix: str = "skfem_mpm"):
    """Within the block, the package's loggers say each warning's text
    once; yields the :class:`OnceEach` filter (``cover()`` it again to
    reach loggers made in the block)."""
    once = OnceEach()
    once.cover(prefix)
    try:
        yield once
    finally:
        for log in once.loggers:
            log.removeFilter(once)
