"""What a material of the user's own returns is checked (trial 97): NaN,
a state written into, missing or extra variables, wrong shapes and types
are refused by an MPMError naming the class, the method, the variable and
the points, with the last converged state; Lame parameters that give a
negative modulus are refused at set-up."""
import numpy as np
import pytest

from skfem import MeshQuad

from skfem_mpm import (InvalidMaterialError, LinearElastic, MaterialPoints,
                       MaterialProtocolError, NonFiniteMaterialError,
                       MPMError, VonMises, seed_points)
from skfem_mpm.mechanics.materials import trusted, update
from test_materials import HardeningVonMises, shear_run

GOOD = HardeningVonMises(1e4, .3, yield_stress=10., H=2e3)


def variant(change):
    """A subclass of the documented model whose return goes through
    ``change(eps, state, out) -> out``."""
    class Model(HardeningVonMises):
        def principal_update(self, eps, state):
            return change(eps, state, list(
                HardeningVonMises.principal_update(self, eps, state)))
    Model.__name__ = change.__name__
    return Model(1e4, .3, yield_stress=10., H=2e3)


def nan_state(eps, state, out):
    out[4] = {"alpha": np.where(out[3], np.nan, out[4]["alpha"])}
    return tuple(out)


def nan_stress(eps, state, out):
    out[0] = np.where(out[3], np.nan, out[0])
    return tuple(out)


def writes_state(eps, state, out):
    state["alpha"] += 1.
    return tuple(out)


def missing(eps, state, out):
    out[4] = {}
    return tuple(out)


def extra(eps, state, out):
    out[4] = dict(out[4], junk=np.zeros(eps.shape[1]))
    return tuple(out)


def tangent_transposed(eps, state, out):
    out[2] = np.ascontiguousarray(out[2].transpose(2, 0, 1))
    return tuple(out)


def tangent_2x2(eps, state, out):
    out[2] = out[2][:2, :2]
    return tuple(out)


def state_short(eps, state, out):
    out[4] = {"alpha": out[4]["alpha"][:-1]}
    return tuple(out)


def yielded_float(eps, state, out):
    out[3] = out[3].astype(float)
    return tuple(out)


def run(material, kinematics):
    return shear_run(4, kinematics, material=material)


@pytest.mark.parametrize("kinematics", ["small", "finite"])
@pytest.mark.parametrize("change, error, variable", [
    (nan_state, NonFiniteMaterialError, "new_state['alpha']"),
    (nan_stress, NonFiniteMaterialError, "tau"),
    (writes_state, MaterialProtocolError, "state['alpha']"),
    (missing, MaterialProtocolError, "new_state"),
    (extra, MaterialProtocolError, "new_state"),
    (tangent_transposed, MaterialProtocolError, "D"),
    (tangent_2x2, MaterialProtocolError, "D"),
    (state_short, MaterialProtocolError, "new_state['alpha']"),
    (yielded_float, MaterialProtocolError, "yielded")])
def test_a_bad_return_is_refused_by_name(change, error, variable,
                                         kinematics):
    """Each ran silently (NaN kappa, a state grown 300-fold, a variable
    left at 0 or carried into checkpoints, a 2 x 2 tangent) or ended in a
    bare numpy broadcasting error or 'Newton did not converge ... nan'
    after 10 cut-backs."""
    material = variant(change)
    with pytest.raises(error) as caught:
        run(material, kinematics)
    err = caught.value
    text = str(err)
    assert isinstance(err, MPMError)
    assert change.__name__ + ".principal_update" in text
    assert "object at 0x" not in text
    cause = err if err.material else err.__cause__
    assert (cause.material, cause.method, cause.variable) == (
        change.__name__, "principal_update", variable)
    assert err.state is not None                  # last converged state
    if error is NonFiniteMaterialError:
        # the points that yield first: the run's indices, named
        assert cause.indices is not None and len(cause.indices) > 0
        assert str(cause.indices[:2])[:-1] in text
    else:
        assert variable.split("[")[-1].strip("]") in text or \
            variable in ("D", "yielded")


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_a_nan_is_said_once_a_step_and_takes_no_ghost_penalty(
        caplog, kinematics):
    """Trial 103: a model's NaN, the same at every attempt, logged 3
    identical warnings at each cut-back (27 lines before the error), and
    in finite strain switched the ghost penalty on, with its limit-load
    caution, which cannot mend a model's arithmetic.  Now the failing
    step says it once at WARNING and the ghost penalty stays off; a NaN
    where the step starts (no increment) is not cut back at all (trial
    119: 8 cut-backs, each evaluating that state again)."""
    def nan_always(eps, state, out):
        out[0] = out[0].copy()
        out[0][0, 0] = np.nan
        return tuple(out)
    with caplog.at_level("WARNING", logger="skfem_mpm"), \
            pytest.raises(NonFiniteMaterialError) as caught:
        run(variant(nan_always), kinematics)
    said = [r for r in caplog.records
            if "nan_always.principal_update" in r.getMessage()]
    cut = [r for r in caplog.records if "cutting" in r.getMessage()]
    assert len(said) <= 1 and not cut
    assert "where the step starts" in str(caught.value)
    assert not any("ghost penalty" in r.getMessage()
                   for r in caplog.records)


def test_the_documented_model_and_shipped_ones_pass_unchanged():
    """The well-formed model runs as before (its state arrays stay
    writable in the points); the package's models are not checked."""
    res = run(GOOD, "small")
    assert res.points.state["alpha"].max() > 0
    assert res.points.state["alpha"].flags.writeable
    assert trusted(VonMises(1e4, .3, 10.)) and not trusted(GOOD)
    state = {"alpha": np.zeros(2)}
    out = update(GOOD, np.zeros((3, 2)), state)
    assert out[4]["alpha"] is state["alpha"]      # unchanged: the same


class OwnElastic:
    """Lame parameters of the user's own (bulk K, shear G)."""
    plastic = True
    state_variables = {}

    def __init__(self, K, G):
        self.lam, self.mu = K - 2 * G / 3, G

    def principal_update(self, eps, state):
        C = self.lam * np.ones((3, 3)) + 2 * self.mu * np.eye(3)
        return C @ eps, eps, np.repeat(C[:, :, None], eps.shape[1], 2), \
            np.zeros(eps.shape[1], bool), {}


@pytest.mark.parametrize("K, G, word", [(-1e4, 3e3, "bulk modulus"),
                                        (1e4, -3e3, "shear modulus"),
                                        (np.nan, 3e3, "lam")])
def test_negative_moduli_of_a_users_material_are_refused(K, G, word):
    """PressureElastic(K0=-1e4) ran into PointsOutsideGridError after a
    warning of 394% strain, the material not named."""
    with pytest.raises(InvalidMaterialError, match="OwnElastic.*" + word):
        run(OwnElastic(K, G), "small")
    assert run(OwnElastic(1e4, 3e3), "small").points.n > 0


def test_a_protocol_gap_is_named_by_class_not_repr():
    class NoLam:
        plastic, mu, state_variables = True, 1., {}

        def principal_update(self, eps, state):
            raise AssertionError
    with pytest.raises(InvalidMaterialError) as caught:
        run(NoLam(), "small")
    assert "material NoLam does not" in str(caught.value)
    assert "object at" not in str(caught.value)


class NaNElastic(OwnElastic):
    """An elastic model of one's own whose stress (small strain's linear
    law) is NaN where the shear strain passes a threshold."""
    plastic = False

    def stress(self, strain):
        tr = np.trace(strain)
        sig = 2 * self.mu * strain + self.lam * tr * np.eye(3)[:, :, None]
        return np.where(np.abs(strain[0, 1]) > 1e-3, np.nan, sig)


def test_nan_in_an_elastic_stress_is_named():
    with pytest.raises(NonFiniteMaterialError,
                       match=r"NaNElastic.stress returned NaN or inf in "
                       r"stress at \d+ point\(s\)"):
        run(NaNElastic(1e4, 3e3), "small")


def test_several_bodies_name_the_runs_point_indices():
    """A user's model as body 1 of two: the indices are the run's, those
    of body 1's points."""
    from skfem import MeshQuad
    from skfem_mpm import seed_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(mesh, 2)
    points.body = (points.x[1] > .5).astype(int)
    bad = variant(nan_state)
    with pytest.raises(NonFiniteMaterialError) as caught:
        shear_run(4, "small", points=points,
                  material=[VonMises(1e4, .3, 1e9), bad])
    cause = caught.value.__cause__ or caught.value
    assert cause.indices and all(points.body[i] == 1
                                 for i in cause.indices)


class Merging(HardeningVonMises):
    """The documented model returning the state it was given merged
    with its own (``{**state, **new}``), recording the names it got."""
    seen = set()

    def principal_update(self, eps, state):
        type(self).seen.update(state)
        out = HardeningVonMises.principal_update(self, eps, state)
        return out[:4] + ({**state, **out[4]},)


@pytest.mark.parametrize("kinematics", ["small", "finite"])
@pytest.mark.parametrize("bodies", [1, 2])
def test_a_model_is_handed_its_own_variables_only(kinematics, bodies):
    """A single model was handed every variable of the run's points (a
    contact's multipliers and offsets, the rotation), then refused for
    returning them ('new_state with 'contact_dx00', ... which its
    state_variables do not declare'); of several bodies each model got
    its own only.  Both hand a model its declared variables; the
    others are carried unchanged."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    base = seed_points(mesh, 2)
    other = np.arange(base.n, dtype=float)
    points = MaterialPoints(x=base.x, volume=base.volume,
                            body=(base.x[1] > .5).astype(int)
                            if bodies == 2 else None,
                            state={"other": other})
    Merging.seen = set()
    model = Merging(1e4, .3, yield_stress=10., H=2e3)
    res = shear_run(4, kinematics, points=points,
                    material=model if bodies == 1 else [model, model])
    assert Merging.seen == {"alpha"}
    assert res.points.state["alpha"].max() > 0
    assert np.array_equal(res.points.state["other"], other)


def test_a_geostatic_start_hands_a_model_its_own_variables_only():
    """The check of a geostatic start against the yield surface called
    the model directly, with every variable of the points."""
    from skfem_mpm import geostatic_stress
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    base = seed_points(mesh, 2)
    points = MaterialPoints(x=base.x, volume=base.volume,
                            state={"other": np.ones(base.n)})
    Merging.seen = set()
    geostatic_stress(points, Merging(1e4, .3, yield_stress=1e3, H=0.),
                     [0., -10.], 1., .5)
    assert Merging.seen == {"alpha"}


class WritesD(LinearElastic):
    """An elastic model of one's own that writes into the tangent
    LinearElastic returns (a read-only broadcast), not into its state."""
    plastic = True

    def principal_update(self, eps, state):
        tau, eps_e, D, yielded, new = LinearElastic.principal_update(
            self, eps)
        D[0, 0] *= 1.
        return tau, eps_e, D, yielded, new


def test_a_read_only_array_of_its_own_is_named_by_the_model():
    """The numpy error 'output array is read-only' came back bare, the
    model not named, where a call on writable copies of the state raised
    it too."""
    with pytest.raises(MaterialProtocolError) as caught:
        update(WritesD(1e4, .3), np.zeros((3, 2)), {})
    text = str(caught.value)
    assert text.startswith("WritesD.principal_update raised ValueError: ")
    assert "read-only" in text.split(",")[0]
    assert "not in writing into its input state" in text
    assert isinstance(caught.value.__cause__, ValueError)


def test_nan_in_an_elastic_stress_of_one_of_several_bodies_is_named():
    """With material=[...] the stress was the linear law of the bodies'
    lam and mu: the user's stress was never called, its NaN unseen."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(mesh, 2)
    points.body = (points.x[1] > .5).astype(int)
    with pytest.raises(NonFiniteMaterialError) as caught:
        shear_run(4, "small", points=points, material=[
            LinearElastic(1e4, .3), NaNElastic(1e4, 3e3)])
    cause = caught.value.__cause__ or caught.value
    assert "NaNElastic.stress returned NaN or inf in stress" in str(
        caught.value)
    assert cause.indices and all(points.body[i] == 1
                                 for i in cause.indices)


def test_the_package_own_is_decided_once():
    """A class of the package's top module (``skfem_mpm``) was the
    package's own to the material checks (split(".")[0]) and a user's to
    the hints (startswith("skfem_mpm.")): one test now decides all."""
    from types import SimpleNamespace
    from skfem_mpm import GridTerm
    from skfem_mpm.errors import NewtonDivergenceError
    from skfem_mpm.solve.core import own_terms_hint
    from skfem_mpm.solve.newton import linear_hint

    class Top(HardeningVonMises):
        pass

    class Term(GridTerm):
        pass
    residuals = [.5 ** k for k in range(8)]        # a linear rate 0.5
    err = NewtonDivergenceError("the residual fell ...: a linear rate")
    for module, own in (("skfem_mpm", True), ("skfem_mpm.x", True),
                        ("skfem_mpmx", False), ("user", False)):
        Top.__module__ = Term.__module__ = module
        model = Top(1e4, .3, yield_stress=10., H=2e3)
        assert trusted(model) is own
        assert ("Top's principal_update" in linear_hint(residuals, model)
                ) is not own
        assert bool(own_terms_hint(SimpleNamespace(user_terms=(Term(),)),
                                   err)) is not own


class Raises(HardeningVonMises):
    def principal_update(self, eps, state):
        return np.linalg.solve(np.zeros((3, 3)), eps)


def test_an_arithmetic_error_of_ones_model_is_named_and_not_retried(
        caplog):
    """Trial 116: a model raising LinAlgError ended as "NumericalError:
    step 1: LinAlgError: Singular matrix" after the ghost penalty and 8
    cut-backs, its class never named; raised where the step starts (no
    increment), every shorter step calls it alike."""
    from skfem_mpm.errors import MaterialRaisedError, NumericalError
    with pytest.raises(MaterialRaisedError) as caught:
        shear_run(2, "finite", material=Raises(1e4, .3, yield_stress=10.,
                                               H=2e3))
    text = str(caught.value)
    assert text.startswith("step 1: Raises.principal_update raised "
                           "LinAlgError: Singular matrix where the step "
                           "starts"), text
    assert "not cut back" in text
    assert isinstance(caught.value, NumericalError)      # (ladder's kind)
    assert caught.value.load_factor == 0.
    assert not [r for r in caplog.records if "cutting" in r.getMessage()
                or "ghost" in r.getMessage()]


class NaNs(HardeningVonMises):
    def principal_update(self, eps, state):
        out = list(super().principal_update(eps, state))
        out[0] = np.full_like(out[0], np.nan)
        return tuple(out)


def test_nan_from_ones_model_where_the_step_starts_is_not_retried(caplog):
    """Trial 119: a model returning NaN at every call was named, but only
    after 8 cut-backs, each evaluating the step's start again."""
    from skfem_mpm.errors import NonFiniteMaterialError
    with pytest.raises(NonFiniteMaterialError) as caught:
        shear_run(2, "finite", material=NaNs(1e4, .3, yield_stress=10.,
                                             H=2e3))
    text = str(caught.value)
    assert text.startswith("step 1: ") and "NaNs.principal_update" in text
    assert "where the step starts" in text and "not cut back" in text
    assert caught.value.load_factor == 0.
    assert not [r for r in caplog.records if "cutting" in r.getMessage()]


def test_a_stalled_newton_names_ones_own_extensions():
    """Trial 116: a model's D halved, a spring bed's matrix 0.3 of its
    derivative: "Newton made no progress (... the body collapsing?)",
    neither named; the words name them, names only."""
    from types import SimpleNamespace
    from skfem_mpm import GridTerm
    from skfem_mpm.solve.newton import stall_words

    class Bed(GridTerm):
        pass
    Bed.__module__ = "user"
    model = variant(lambda eps, state, out: tuple(out))
    model.__class__.__name__ = "Halved"
    type(model).__module__ = "user"
    problem = SimpleNamespace(run=SimpleNamespace(material=model),
                              terms=[Bed()])
    words = stall_words(("flat", 1.), problem)
    assert "Newton made no progress" in words
    assert "the tangent D of Halved's principal_update may not be the " \
        "derivative of its stress" in words
    assert "the matrix of Bed may not be the derivative of its force" \
        in words
    type(model).__module__ = "skfem_mpm.x"
    Bed.__module__ = "skfem_mpm.y"
    assert "may not be" not in stall_words(("flat", 1.), problem)
