"""A new user's study whose values differ by the solver's round-off alone
(session 85, trial 1): a wall pushed along a Coulomb floor, mpm and
cpgimp on 14, 28 and 56 elements, every push within 2.6e-9 of Coulomb's
mu W = 24 kN/m (Newton tolerance 1e-9).  The study had fitted a rate
2.93 and extrapolated from those differences, and said "push disagrees
... 0.00% apart, further than their uncertainties"; ``compare`` printed
"largest displacement 0.0298" with no unit."""
from dataclasses import replace

import numpy as np
import pytest

from skfem_mpm.scenes.quantities import Quantity
from skfem_mpm.scenes.scene_file import parse_scene, tomllib
from skfem_mpm.studies.convergence import self_convergence
from skfem_mpm.studies.figures import curve_label
from skfem_mpm.studies.study import analyse, report

WALL = """
name = "wall-slide"
units = "kN-m"
[grid]
x = [-0.5, 3.0, 28]
y = [-0.25, 2.5, 22]
[[bodies]]
name = "wall"
region = { x = [0.0, 1.0], y = [0.0, 2.0] }
points_per_cell = 2
material = { model = "linear_elastic", E = 2e6, nu = 0.2 }
[gravity]
body_force = [0.0, -24.0]
ramp = false
[[obstacles]]
name = "floor"
box = { x = [-1.0, 4.0], y = [-1.0, 0.0] }
friction = 0.5
[[obstacles]]
name = "pusher"
box = { x = [-1.0, 0.0], y = [0.25, 1.0] }
displacement = [0.25, 0.0]
friction = 0.0
[solver]
method = "mpm"
steps = 40
"""
PUSH = Quantity("obstacle_force", "x", obstacle="pusher", name="push")
SLIDE = Quantity("displacement", "x", at=(1., 0.), name="slide")
#: the trial's values (study.csv): (elements, method) -> (push, slide)
VALUES = {(14, "mpm"): (-24.000000061685, 0.24996920703630857),
          (14, "cpgimp"): (-24.00000000000293, 0.2499720429222557),
          (28, "mpm"): (-23.999999999469868, 0.24996696827297213),
          (28, "cpgimp"): (-24.00000000001197, 0.24997109113855673),
          (56, "mpm"): (-23.999999991564227, 0.24996463091644514),
          (56, "cpgimp"): (-23.999999999510518, 0.24996980064532656)}


def rows(push=lambda v: v):
    return [dict(elements=n, method=m, failure="", points=128 * (n // 14)
                 ** 2, ghost_from_step=0 if m == "mpm" else 2,
                 values={"push": push(p), "slide": s}, wall_seconds=1.,
                 cpu_seconds=1., newton_iterations=300, factorisations=300)
            for (n, m), (p, s) in VALUES.items()]


def test_values_within_the_solver_s_round_off_agree_and_have_no_rate():
    """The push of both methods converged to round-off: no order, no
    extrapolation, no rate of its errors, no disagreement and no NOTE of
    "0.00% apart"; round-off is 10 times the scene's Newton tolerance
    of the values (1e-8), so the same differences against a tolerance
    of 1e-12 are differences, and so are differences 1e4 times
    larger."""
    scene = parse_scene(tomllib.loads(WALL))
    assert scene.newton.tol == 1e-9
    found = rows()
    measured = analyse(scene, found, [PUSH, SLIDE])
    assert measured["error"]["roundoff"] == 1e-8
    push = [c for c in measured["convergence"] if c["quantity"] == "push"]
    assert [c["choices"] for c in push] == [{"method": "mpm"},
                                            {"method": "cpgimp"}]
    for c in push:
        assert c["basis"] == "round-off" and c["order"] is None
        assert c["against"] == "finest" and c["roundoff"] == 1e-8
        assert c["why"].startswith(
            "converged to round-off (differences within 1e-08 of the "
            "values: 10 x the solver's tolerance 1e-09): no order")
        assert c["reference"] == VALUES[56, c["choices"]["method"]][0]
        assert c["uncertainty"] == pytest.approx(3e-8 * max(
            abs(v) for v in c["values"]), rel=1e-12)
    assert measured["disagreements"] == []
    # every error at least round-off, the finest's unknown
    for r in found:
        if r["elements"] == 56:
            assert np.isnan(r["error"])
        else:
            assert 1e-8 <= r["error"] < 1.01e-8
    lines = report(found, measured, ["elements", "method"])
    rates = [x for x in lines if x.startswith("rate of the error")]
    assert rates == [
        "rate of the error method={}: none: push converged to round-off "
        "(within 1e-08 of the values: 10 x the solver's tolerance 1e-09), "
        "no rate".format(m) for m in ("mpm", "cpgimp")]
    assert not any("disagrees" in x or x.startswith("NOTE") or "0.00%" in x
                   for x in lines), lines
    # the figure's legend says so too
    assert curve_label(measured, "method=mpm", [
        r for r in found if r["method"] == "mpm"]) == \
        "method=mpm (converged to round-off: no rate)"
    # against a tolerance of 1e-12 the same differences are no round-off
    tight = replace(scene, newton=replace(scene.newton, tol=1e-12))
    measured = analyse(tight, rows(), [PUSH])
    assert measured["error"]["roundoff"] == pytest.approx(1e-11)
    assert all(c["basis"] != "round-off" for c in measured["convergence"])
    # nor are differences 1e4 times larger
    measured = analyse(scene, rows(lambda v: -24. + 1e4 * (v + 24.)),
                       [PUSH])
    assert all(c["basis"] != "round-off" for c in measured["convergence"])


def test_the_two_finest_grids_at_round_off_give_no_order():
    """Where the two finest values agree to round-off and a coarser one
    does not, an order through the three would be fitted to a round-off
    difference: the reference is the finest value, not extrapolated."""
    values = [1.1, 1. + 5e-9, 1.]
    c = self_convergence([.4, .2, .1], values, tol=1e-9)
    assert c.basis == "round-off" and c.order is None and c.reference == 1.
    assert c.why.startswith("converged to round-off on the finest grids")
    assert c.uncertainty == pytest.approx(3 * .1, rel=1e-12)
    # with the arithmetic's round-off alone (no tolerance) they differ
    assert self_convergence([.4, .2, .1], values).basis != "round-off"


def closed_form_line(errors, elements=(8, 16, 32, 64)):
    rows = [dict(elements=n, failure="", error=e, uncertainty=None,
                 wall_seconds=1., cpu_seconds=1., points=n * n,
                 newton_iterations=1, factorisations=1)
            for n, e in zip(elements, errors)]
    measured = {"error": {"measures": "a closed form", "closed_form": True,
                          "roundoff": 1e-8, "roundoff_is": "1e-08 of the "
                          "values: 10 x the solver's tolerance 1e-09"},
                "convergence": []}
    return [x for x in report(rows, measured, ["elements"])
            if x.startswith("rate of the error")][0]


def test_errors_at_round_off_are_left_out_of_a_rate():
    """Against a closed form, errors at round-off (at most 1e-8 here)
    are no part of a rate: a 64-element error of 5e-9 after 4e-3, 1e-3
    and 2.5e-4 (rate 2) would have pulled the slope to 6.1; all at
    round-off give none."""
    said = closed_form_line([4e-3, 1e-3, 2.5e-4, 5e-9])
    assert said.startswith("rate of the error all: 2.00 (least squares "
                           "over 8, 16, 32 elements"), said
    assert said.endswith("; left out, their errors round-off (at most "
                         "1e-08, 1e-08 of the values: 10 x the solver's "
                         "tolerance 1e-09): 64 elements")
    assert closed_form_line([3e-9, 4e-10, 5e-11, 1e-8]) == (
        "rate of the error all: none: the errors are round-off, no rate; "
        "left out, their errors round-off (at most 1e-08, 1e-08 of the "
        "values: 10 x the solver's tolerance 1e-09): 8, 16, 32, 64 "
        "elements")
