"""The elastica of an end-loaded cantilever: the large-deflection reference
for beam benchmarks.

With arc length ``s`` in [0, 1] (units of the length L) and rotation
``theta(s)``, a tip force of fixed vertical direction gives
``theta'' + alpha cos(theta) = 0``, ``theta(0) = 0``, ``theta'(1) = 0``,
``alpha = P L^2 / (E I)``.  Tip deflections: ``v/L = int sin(theta) ds``
and ``u/L = 1 - int cos(theta) ds`` (Bisshopp and Drucker, *Q. Appl.
Math.* 3, 1945, solved here numerically).

"""
import numpy as np
from numpy import ndarray
from scipy.integrate import solve_bvp, trapezoid

__all__ = ["elastica_tip", "untuned_cantilever"]


def elastica_tip(alphas: ndarray, nodes: int = 401):
    """Vertical and horizontal tip deflections over L of the elastica.

    Parameters
    ----------
    alphas
        Load parameters ``P L^2 / (E I)``, increasing (solved by
        continuation from the linear solution).

    Returns
    -------
    v, u
        Vertical and horizontal tip deflections over L, shape of alphas.

    Examples
    --------
    >>> from skfem_mpm.studies.elastica import elastica_tip
    >>> v, u = elastica_tip([1e-3])
    >>> round(float(v[0] / 1e-3), 4)    # small loads: v/L = alpha / 3
    0.3333

    """
    s = np.linspace(0., 1., nodes)
    guess = np.zeros((2, nodes))
    v, u = [], []
    for alpha in np.atleast_1d(alphas):
        if not guess.any():
            guess = np.array([alpha * (s - s ** 2 / 2), alpha * (1 - s)])

        def rhs(_, y, alpha=alpha):
            return np.vstack((y[1], -alpha * np.cos(y[0])))

        def bc(ya, yb):
            return np.array([ya[0], yb[1]])

        sol = solve_bvp(rhs, bc, s, guess, tol=1e-10, max_nodes=100000)
        if not sol.success:
            raise RuntimeError("elastica did not converge at alpha = {}: {}"
                               .format(alpha, sol.message))
        theta = sol.sol(s)[0]
        guess = sol.sol(s)
        v.append(trapezoid(np.sin(theta), s))
        u.append(1. - trapezoid(np.cos(theta), s))
    return np.array(v), np.array(u)


def untuned_cantilever(h: float, per_cell: int, method: str,
                       alpha: float = 3., nsteps: int = 20,
                       options=None):
    """A cantilever set up as a new user would (length 10, depth 1,
    E = 1e6, nu = 0, clamped root, the end load spread over the tip points,
    ``P L^2 / (E I) = alpha``, a grid of spacing ``h`` around it, finite
    deformation, every other setting the default unless ``options`` (an
    :class:`~skfem_mpm.Options`) say otherwise): returns the result and the
    relative error of the tip deflection against the elastica.

    Examples
    --------
    >>> from skfem_mpm.studies.elastica import untuned_cantilever
    >>> res, error = untuned_cantilever(.5, 2, "mpm", alpha=1., nsteps=4)
    >>> round(float(error), 3)
    0.014

    """
    from skfem import ElementQuad1, MeshQuad
    from ..quadrature.points import seed_points
    from ..solve.core import simulate
    from ..mechanics.materials import LinearElastic
    L, E = 10., 1e6
    mesh = MeshQuad.init_tensor(np.arange(0, L + 1 + 1e-9, h),
                                np.arange(-8, 2 + 1e-9, h))
    points = seed_points(mesh, per_cell, region=lambda x: (x[0] < L)
                         & (x[1] > 0) & (x[1] < 1))
    tip = np.flatnonzero(points.x[0] > points.x[0].max() - 1e-9)
    points.force[1, tip] = -alpha * E / 12 / L ** 2 / tip.size
    res = simulate(mesh, ElementQuad1(), points, LinearElastic(E, 0.),
                   lambda b: b.get_dofs(lambda x: x[0] == 0), nsteps=nsteps,
                   method=method, kinematics="finite", options=options)
    deflection = -res.points.displacement[1, tip].mean() / L
    return res, abs(deflection / elastica_tip(np.array([alpha]))[0][0] - 1)
