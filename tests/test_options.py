"""Options as objects: each validates itself on creation, simulate takes
them as ``options=``, and the keyword arguments they replaced are
deprecated aliases that compute the same run bit for bit."""
import warnings

import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (BodyForce, InvalidInputError, LinearElastic,
                       NewtonOptions, Options, Prescribed, Resume,
                       Stabilisation, VonMises, seed_points, simulate,
                       solve_finite, solve_mpm)


def block():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    return mesh, seed_points(mesh, 2, region=lambda x: x[1] < 1.3)


def bottom(b):
    return b.get_dofs(lambda x: x[1] == 0)


def test_old_keywords_are_deprecated_aliases_of_the_same_run():
    mesh, points = block()
    pushed = np.flatnonzero(np.isclose(mesh.p[1], 1.) & (mesh.p[0] < .6))

    def push(b, f_old, f_new):
        return b.nodal_dofs[1, pushed], np.full(pushed.size,
                                                -.01 * (f_new - f_old))
    args = (mesh, ElementQuad1(), points, VonMises(1e4, .3, 40.), bottom)
    with pytest.warns(DeprecationWarning, match=r"simulate\(antilocking="
                      r"\.\.\., ghost=\.\.\., line_search=\.\.\., "
                      r"prescribed=\.\.\., ramp_body_force=\.\.\., "
                      r"tol=\.\.\.\) is deprecated"):
        old = simulate(*args, body_force=[0., -10.], nsteps=2,
                       kinematics="finite", tol=1e-10, ghost=.1,
                       antilocking=True, line_search="armijo",
                       prescribed=push, ramp_body_force=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")         # the new API warns nothing
        new = simulate(*args, BodyForce([0., -10.], ramp=False),
                       [Prescribed(push)], 2, kinematics="finite",
                       options=Options(NewtonOptions(
                           tol=1e-10, line_search="armijo"),
                           Stabilisation(ghost=.1, antilocking=True)))
    assert old.counters == new.counters
    for name in ("x", "stress", "volume"):
        assert np.array_equal(getattr(old.points, name),
                              getattr(new.points, name)), name
    for entry, alias in ((solve_mpm, "solve_mpm"),
                         (solve_finite, "solve_finite")):
        with pytest.warns(DeprecationWarning, match=alias + r"\(tol="):
            entry(*args[:3], LinearElastic(1e4, .3), bottom, tol=1e-10)


@pytest.mark.parametrize("method", ["mpm", "fem"])
def test_resume_after_a_record_continues_bit_identically(method):
    """``Resume.after(record)`` from the state a callback saw after step 2
    of 4: the resumed run ends where the whole run does, bit for bit, its
    counters too (the resumed run's location of its points counted once
    more: ``locate`` 6 instead of 5 for MPM, 2 instead of 1 for FE)."""
    mesh, points = block()
    args = (mesh, ElementQuad1(), points, VonMises(1e4, .3, 30.), bottom,
            [0., -20.])
    saved = {}

    def keep(record, state):
        if record.step == 2:
            saved.update(record=record, state=state)
    whole = simulate(*args, nsteps=4, kinematics="finite", method=method,
                     options=Options(callback=keep))
    rest = simulate(mesh, ElementQuad1(), saved["state"],
                    VonMises(1e4, .3, 30.), bottom, [0., -20.], nsteps=4,
                    kinematics="finite", method=method, options=Options(
                        resume=Resume.after(saved["record"],
                                            points.domain)))
    assert [r.step for r in rest.history] == [3, 4]
    for name in ("x", "stress", "volume", "domain"):
        assert np.array_equal(getattr(rest.points, name),
                              getattr(whole.points, name)), name
    # one location a step (MPM: the points move) and the initial one
    assert whole.counters["locate"] == (1 if method == "fem" else 4 + 1)
    assert rest.counters == whole.counters


@pytest.mark.parametrize("make, match", [
    (lambda: NewtonOptions(tol=0.), r"tol must lie in \(0, 1\)"),
    (lambda: NewtonOptions(tol="1e-9"), "tol must be a number"),
    (lambda: NewtonOptions(max_iter=0), r"max_iter must be an integer in "
     r"\[1, 60\], got 0"),
    (lambda: NewtonOptions(max_cutbacks=True), "max_cutbacks must be an "
     "integer"),
    (lambda: NewtonOptions(line_search="wolfe"), "line_search must be one "
     "of"),
    (lambda: NewtonOptions(newton="quasi"), "newton must be one of"),
    (lambda: NewtonOptions(rhs="load"), "rhs must be one of"),
    (lambda: Stabilisation(ghost=np.inf), "ghost must be 'auto' or a "
     "finite number"),
    (lambda: Stabilisation(antilocking="yes"), "antilocking must be True, "
     "False or 'fbar'"),
    (lambda: Resume(first_step=0), "first_step must be an integer >= 1"),
    (lambda: Options(newton=NewtonOptions, ), "Options.newton must be a "
     "NewtonOptions"),
    (lambda: Options(stabilisation={"ghost": .1}), "Options.stabilisation "
     "must be a Stabilisation"),
    (lambda: Options(callback=3), "callback must be callable"),
    (lambda: Prescribed(3), "Prescribed needs a function"),
])
def test_options_refuse_bad_values_on_creation(make, match):
    with pytest.raises(InvalidInputError, match=match):
        make()


def test_simulate_refuses_what_it_cannot_use():
    """An unknown keyword, an options object of another kind, a resume
    given twice, two prescribed motions: refused before any work, with the
    reason."""
    mesh, points = block()
    args = (mesh, ElementQuad1(), points, LinearElastic(1e4, .3), bottom)
    fail = dict(options=Options(callback=pytest.fail))
    with pytest.raises(InvalidInputError, match="unexpected keyword "
                       "argument"):
        simulate(*args, tolerance=1e-9)
    with pytest.raises(InvalidInputError, match="options must be an "
                       "Options"):
        simulate(*args, options=NewtonOptions())
    for given, keyword in ((Options(resume=Resume()), dict(first_step=2)),
                           (Options(NewtonOptions(tol=1e-4)),
                            dict(tol=1e-12)),
                           (Options(solver="scipy"), dict(solver="pyamg")),
                           (Options(stabilisation=Stabilisation(ghost=.1)),
                            dict(ghost=0.))):
        with pytest.raises(InvalidInputError, match="{} given both in "
                           "options and as keyword".format(*keyword)), \
                pytest.warns(DeprecationWarning):
            simulate(*args, options=given, **keyword)
    with pytest.raises(InvalidInputError, match="BodyForce.value must be "
                       "finite numbers"):
        BodyForce("abc")
    with pytest.raises(InvalidInputError, match="Resume.first_step 5 is "
                       "beyond the run's 2 steps"):
        simulate(*args, nsteps=2, options=Options(resume=Resume(5)))
    push = Prescribed(lambda b, f0, f1: (np.array([0]), np.zeros(1)))
    with pytest.raises(InvalidInputError, match="2 Prescribed items"):
        simulate(*args, loads=[push, push], **fail)
    with pytest.raises(InvalidInputError, match="one bool per body"):
        simulate(*args, BodyForce([0., -1.], ramp=[True, False]), **fail)


def test_entry_points_keep_their_positional_order_and_scenes_their_types():
    """``solve_mpm(..., body_force, nsteps)`` and ``solve_finite(...,
    body_force, nsteps, method)`` as before the options; a scene holding a
    string where an option object belongs is refused by name; a scene
    file's bad Newton setting is named by its file key."""
    from skfem_mpm.scenes.scene import Body, Grid, Scene, Support
    from skfem_mpm.scenes.scene_file import parse_scene
    from skfem_mpm.errors import SceneError
    mesh, points = block()
    args = (mesh, ElementQuad1(), points, LinearElastic(1e4, .3), bottom,
            [0., -10.])
    assert len(solve_mpm(*args, 3).history) == 3
    assert len(solve_finite(*args, 2, "cpgimp").history) == 2
    scene = Scene(grid=Grid([(0., 2., 2), (0., 2., 2)]),
                  bodies=[Body("b", [(0., 2.), (0., 1.)],
                               LinearElastic(1e4, .3))],
                  supports=[Support(boundary="bottom")], newton="modified")
    with pytest.raises(InvalidInputError, match="Scene.newton must be a "
                       "NewtonOptions"):
        scene.check()
    data = {"grid": {"x": [0., 2., 2], "y": [0., 2., 2]},
            "bodies": [{"name": "b", "box": {"x": [0., 2.], "y": [0., 1.]},
                        "material": {"model": "linear_elastic", "E": 1e4,
                                     "nu": .3}}],
            "supports": [{"boundary": "bottom"}],
            "solver": {"tolerance": 2., "max_iterations": 3}}
    with pytest.raises(SceneError, match=r"solver.tolerance: must lie in "
                       r"\(0, 1\), got 2"):
        parse_scene(data)


def test_a_deprecated_keyword_names_its_new_field():
    """Trial 86: simulate(..., rhs=...) said "use
    options=Options(newton=...)" without the field's name; now
    options=Options(newton=NewtonOptions(rhs=...))."""
    import warnings
    from skfem_mpm.solve.options import translate_aliases
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        translate_aliases("simulate", None, None, None,
                          {"rhs": "increment", "ghost": .1})
    assert [str(w.message) for w in caught] == [
        "simulate(ghost=..., rhs=...) is deprecated: use "
        "options=Options(newton=NewtonOptions(rhs=...)), "
        "options=Options(stabilisation=Stabilisation(ghost=...))"]
