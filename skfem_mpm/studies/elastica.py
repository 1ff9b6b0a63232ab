"""The elastica of an end-loaded cantilever: the large-deflection reference
for beam benchmarks.

With arc length ``s`` in [0, 1] (units of the length L) and rotation
``theta(s)``, a tip force of fixed vertical direction gives
``theta'' + alpha cos(theta) = 0``, ``theta(0) = 0``, ``theta'(1) = 0``,
``alpha = P L^2 / (E I)``.  Tip deflections: ``v/L = int sin(theta) ds``
and ``u/L = 1 - int cos(theta) ds``.

"""
import numpy as np
from numpy import ndarray
from scipy.integrate import solve_bvp, trapezoid

__all__ = ["elastica_tip"]


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
