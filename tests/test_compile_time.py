"""numba's compilation is timed and left out of a run's times
(:func:`skfem_mpm.kernels.run_clock`): a trial's first run on an empty
kernel cache took 27 s where the run took 0.7 s, 91% booked to the
assembly, without a word."""
import logging
import time

import pytest

from skfem_mpm import kernels

numba = pytest.importorskip("numba")


def test_compilation_is_counted_once_and_left_out_of_the_clock(caplog):
    """A function compiled after the passes were asked for: its seconds
    (an outer function compiling an inner one counts once) are added to
    :func:`compile_seconds` and missing from :func:`run_clock`'s
    interval, which is the perf counter's less them (to 1 ms); the first
    compilation is logged at INFO."""
    assert kernels.compiled_passes() is not None

    @numba.njit
    def inner(x):
        return 2 * x

    @numba.njit
    def outer(x):
        return inner(x) + 1

    kernels._LOGGED.clear()
    before, tic, wall = (kernels.compile_seconds(), kernels.run_clock(),
                         time.perf_counter())
    with caplog.at_level(logging.INFO, logger="skfem_mpm"):
        assert outer(20) == 41
    spent = kernels.compile_seconds() - before
    wall = time.perf_counter() - wall
    measured = kernels.run_clock() - tic
    assert 0. < spent <= wall
    assert measured == pytest.approx(wall - spent, abs=1e-3)
    assert "compiling the kernels" in caplog.text
    assert outer(1) == 3                # compiled: nothing added
    assert kernels.compile_seconds() - before == spent
