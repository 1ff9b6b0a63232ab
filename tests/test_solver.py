import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (InvalidInputError, Options, InvalidMaterialError, LinearElastic,
                       MaterialPoints, PointsOutsideGridError,
                       SingularSystemError, seed_gauss_points, seed_points,
                       solve_mpm)
from skfem_mpm.studies.column import (column_error, column_grid, run_column,
                              vertical_stress)
from skfem_mpm.solve.fe import solve_fe

MAT = LinearElastic(E=210., nu=.3)


def fixed_at_min_x(basis):
    return basis.get_dofs(lambda x: np.isclose(x[0], 0.)).all()


def body_force(dim):
    b = np.zeros(dim)
    b[-1] = -1.
    b[0] += .5
    return b


def test_one_step_mpm_at_gauss_points_is_fe(family):
    """FE parity to round-off for every element family."""
    name, mesh, elem = family
    b = body_force(mesh.dim())
    # stiff enough that the points near the grid's edges stay in the grid
    material = LinearElastic(E=2100., nu=.3)
    fe = solve_fe(mesh, elem, material, fixed_at_min_x, body_force=b,
                  intorder=2)
    res = solve_mpm(mesh, elem, seed_gauss_points(mesh, 2), material,
                    fixed_at_min_x, body_force=b, nsteps=1)
    u_mp = res.history[0].u
    assert np.abs(fe.u).max() > 1e-4
    assert np.abs(u_mp - fe.u).max() <= 1e-10 * np.abs(fe.u).max()
    # stresses at the points equal the FE stresses at the Gauss points
    s_fe = fe.stress.reshape(3, 3, -1)
    assert np.abs(res.points.stress - s_fe).max() <= \
        1e-10 * np.abs(s_fe).max()
    assert res.history[0].residual < 1e-10


def test_column_one_step_converges_at_rate_one():
    nel = np.array([4, 8, 16, 32, 64, 128, 256])
    err = np.array([column_error(run_column(n, 2, 1).points) for n in nel])
    rate = np.polyfit(np.log(nel), -np.log(err), 1)[0]
    assert abs(rate - 1.) <= .1
    # two points per element at the sub-cell centres: error h / (4 L0)
    np.testing.assert_allclose(err, 1 / (4 * nel), rtol=1e-9)


def test_column_twenty_steps_plateaus():
    """With 20 load steps the error stops decreasing: the small-strain
    model with moving points, MPM's grid crossing on top
    (``test_examples.py::test_column_plateau_is_the_small_strain_model``)."""
    nel = np.array([4, 16, 64, 256])
    err = np.array([column_error(run_column(
        n, 2, 20, options=Options(keep_snapshots=False))
                                 .points) for n in nel])
    one_step = 1 / (4 * nel)
    assert err[0] == pytest.approx(one_step[0], rel=1e-6)  # no crossing yet
    assert (err[1:] > 1e-2).all()
    assert err[-1] > .5 * err[1]
    assert err[-1] > 20 * one_step[-1]
    rate = np.polyfit(np.log(nel[1:]), -np.log(err[1:]), 1)[0]
    assert abs(rate) < .1


def test_column_2d_equals_1d():
    for nsteps in (1, 20):
        r1 = run_column(16, 2, nsteps)
        r2 = run_column(16, 2, nsteps, dim=2)
        p1, p2 = r1.points, r2.points
        left = p2.x0[0] < p2.x0[0].mean()
        o1, o2 = np.argsort(p1.x0[0]), np.argsort(p2.x0[1][left])
        s1, s2 = vertical_stress(p1)[o1], vertical_stress(p2)[left][o2]
        assert np.abs(s1 - s2).max() < 1e-12 * np.abs(s1).max()
        assert np.abs(p1.x[0][o1] - p2.x[1][left][o2]).max() < 1e-12
        assert abs(column_error(p1) - column_error(p2)) < 1e-14


def test_column_conserves_volume_and_weight():
    res = run_column(32, 3, 20)
    pts = res.points
    assert abs(pts.volume.sum() - 50.) < 1e-12
    # equilibrium in every step; the base reaction is the full weight
    assert max(r.residual for r in res.history) < 1e-10
    assert abs(pts.displacement[0].min() + 1.) < .02
    assert [r.load_factor for r in res.history][-1] == 1.
    assert set(res.timings()) == {"locate", "assemble", "solve", "update",
                                  "check"}


def test_point_forces_are_mapped_and_ramped():
    mesh, elem = column_grid(10, dim=1)
    pts = seed_points(mesh, 1)
    pts.force[0, -1] = -100.        # the top point is pushed down
    res = solve_mpm(mesh, elem, pts, LinearElastic(1e4, 0.),
                    lambda b: b.get_dofs(lambda x: x[0] == 0), nsteps=1)
    # the point at the top element's centre sends half its force to the top
    # node: that element carries -50, every element below it -100
    stress = vertical_stress(res.points)
    np.testing.assert_allclose(stress[:-1], -100., rtol=1e-12)
    assert stress[-1] == pytest.approx(-50., rel=1e-12)
    assert res.points.force[0, -1] == -100.     # the input is unchanged


def test_fe_mode_keeps_points_still():
    mesh, elem = column_grid(8, dim=1)
    pts = seed_points(mesh, 2)
    res = solve_mpm(mesh, elem, pts, LinearElastic(1e6, 0.),
                    lambda b: b.get_dofs(lambda x: x[0] == 0),
                    body_force=[-800.], nsteps=5, update_positions=False)
    np.testing.assert_array_equal(res.points.x, pts.x)
    # linear problem, fixed quadrature: five steps give the one-step answer
    one = solve_mpm(mesh, elem, pts, LinearElastic(1e6, 0.),
                    lambda b: b.get_dofs(lambda x: x[0] == 0),
                    body_force=[-800.], nsteps=1)
    assert np.abs(res.points.stress - one.points.stress).max() < 1e-8


def square():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 2, 3))
    return mesh, ElementQuad1(), seed_points(mesh, 2)


def test_no_supports_is_a_singular_system():
    mesh, elem, pts = square()
    with pytest.raises(SingularSystemError, match="step 1: a body on 9 grid "
                       "nodes .* touches no supported node"):
        solve_mpm(mesh, elem, pts, MAT, np.array([], dtype=int),
                  body_force=[0., -1.])


@pytest.mark.parametrize("supports", [
    # vertical rollers on the base: free horizontal translation
    lambda b: b.get_dofs(lambda x: x[1] == 0).nodal["u^2"],
    # one pinned corner: free rotation
    lambda b: b.nodal_dofs[:, b.mesh.nodes_satisfying(
        lambda x: (x[0] == 0) & (x[1] == 0))].ravel(),
])
def test_insufficient_supports_are_a_singular_system(supports):
    mesh, elem, pts = square()
    with pytest.raises(SingularSystemError, match="step 1: a body on 9 grid "
                       "nodes .* not held against (translation along x|"
                       "rotation)"):
        solve_mpm(mesh, elem, pts, MAT, supports, body_force=[0., -1.])


def test_points_leaving_the_grid_name_the_step():
    mesh, elem = column_grid(4, dim=1)
    pts = seed_points(mesh, 2)
    with pytest.raises(PointsOutsideGridError, match="outside the grid") \
            as err:
        solve_mpm(mesh, elem, pts, LinearElastic(1e3, 0.),
                  lambda b: b.get_dofs(lambda x: x[0] == 0),
                  body_force=[800.], nsteps=4)
    # the update of step 1 moves points out of the grid: the error names
    # step 1 and carries the state before it
    assert err.value.step == 1 and err.value.indices.size > 0
    assert np.array_equal(err.value.state.x, pts.x)


@pytest.mark.parametrize("E, nu, match", [
    (0., .3, "E must be positive"), (-1., .3, "E must be positive"),
    (np.nan, .3, "E must be positive"), (1., .5, r"nu must lie in"),
    (1., -1., "nu must lie in"), (1., .7, "got 0.7"),
])
def test_bad_material(E, nu, match):
    with pytest.raises(InvalidMaterialError, match=match):
        LinearElastic(E, nu)


def test_bad_solver_input():
    mesh, elem, pts = square()
    sup = lambda b: b.get_dofs(lambda x: x[1] == 0)
    with pytest.raises(InvalidInputError, match="body_force must have 2"):
        solve_mpm(mesh, elem, pts, MAT, sup, body_force=[1.])
    with pytest.raises(InvalidInputError, match="body_force holds 1 non-fin"):
        solve_mpm(mesh, elem, pts, MAT, sup, body_force=[0., np.inf])
    with pytest.raises(InvalidInputError, match="nsteps"):
        solve_mpm(mesh, elem, pts, MAT, sup, nsteps=0)
    with pytest.raises(InvalidInputError, match="points are 1D"):
        solve_mpm(mesh, elem, MaterialPoints(x=[[.5]], volume=[1.]), MAT, sup)
    with pytest.raises(InvalidInputError, match="support DOF indices"):
        solve_mpm(mesh, elem, pts, MAT, np.array([0, 10**6]))


def test_weak_equilibrium_with_a_linear_test_field():
    """With v = (0, y), zero on the fixed base, the discrete weak form gives
    sum_p sigma_yy V_p = sum_p y_p b_y V_p exactly after one step."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 5), np.linspace(0, 12, 13))
    pts = seed_points(mesh, 3, region=lambda x: x[1] < 10)
    res = solve_mpm(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                    lambda b: b.get_dofs(lambda x: x[1] == 0),
                    body_force=[0., -800.])
    total = res.points.stress[1, 1] @ pts.volume
    assert total == pytest.approx(-800. * pts.x[1] @ pts.volume, rel=1e-12)
    assert total == pytest.approx(-160000., rel=1e-12)


def test_zero_energy_mode_of_a_lone_point_is_refused():
    """One point alone in a cell: its two unshared nodes (4 DOFs) meet only
    3 strain components, a zero-energy mode.  A load with a component along
    it (here a horizontal body force) has no solution: refused.  (Vertical
    gravity is orthogonal to this mode and is solved.)"""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 2, 3))
    body = seed_points(mesh, 2, region=lambda x: x[1] < 1)
    lone = MaterialPoints(x=[[.3], [1.6]], volume=[.25], domain=[[.25], [.25]])
    from skfem_mpm.quadrature.points import concatenate_points
    pts = concatenate_points([body, lone])
    with pytest.raises(SingularSystemError, match="zero-energy mode"):
        solve_mpm(mesh, ElementQuad1(), pts, MAT,
                  lambda b: b.get_dofs(lambda x: x[1] == 0),
                  body_force=[.5, -1.])


def test_the_fe_stiffness_keeps_every_element_entry(monkeypatch):
    """scikit-fem's ``asm`` drops element entries that come out exactly
    zero (P1 on right triangles: 480 of 548 at nu = 0.25), which ones
    depending on the CPU's vector loops; the solver "auto" chooses from
    the pattern's bandwidth, so ``solve_fe``'s choice changed with the
    machine.  Its stiffness holds every pair of DOFs an element couples,
    counted here from the elements."""
    import skfem_mpm.solve.fe as fe_module
    from skfem import ElementTriP1, MeshTri
    seen = []
    solve = fe_module.solve_active
    monkeypatch.setattr(fe_module, "solve_active", lambda K, *a, **kw: (
        seen.append(K), solve(K, *a, **kw))[1])
    mesh = MeshTri().refined(2)
    fe = solve_fe(mesh, ElementTriP1(), LinearElastic(1., .25),
                  fixed_at_min_x, body_force=[0., -1.])
    dofs = fe.basis.element_dofs
    pairs = np.unique(np.stack([np.repeat(dofs, dofs.shape[0], axis=0),
                                np.tile(dofs, (dofs.shape[0], 1))]).reshape(
                                    2, -1), axis=1)
    K, = seen
    assert K.nnz == pairs.shape[1]
    assert np.count_nonzero(K.data) < K.nnz    # the premise: exact zeros
