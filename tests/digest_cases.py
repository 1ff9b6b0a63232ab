"""Small runs through every piece of the load-step core, and a fingerprint
of what each computes: positions, stresses, state, velocities and every
number of its history.  ``tests/data/core_digests.json`` holds the
fingerprints of these runs as computed before the core was split into a
step problem, a Newton driver and grid terms; ``test_digest.py`` asserts
that the runs are unchanged.

``python tests/digest_cases.py`` prints the fingerprints as JSON (how the
stored file was written, on the commit before the split)."""
import ctypes
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import scipy
import skfem
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (Dynamics, GeneralizedAlpha, LinearElastic, Pressure,
                       RigidBody, Traction, VonMises, seed_points,
                       side_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points


def bottom(b):
    return b.get_dofs(lambda x: x[1] == 0)


def block(nx=6, ny=5, top=1.3, per_cell=2, region=None):
    mesh = MeshQuad.init_tensor(np.linspace(0, 3, nx + 1),
                                np.linspace(0, 2.5, ny + 1))
    points = seed_points(mesh, per_cell, region=region or (
        lambda x: (x[0] < 2) & (x[1] < top)))
    return mesh, points


def linear_traction():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e4, .3),
                    bottom, body_force=[0., -20.], loads=[Traction(
                        side_points(points, "top"), "top", [5., -3.])],
                    nsteps=3)


def linear_increment():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e4, .3),
                    bottom, body_force=[0., -20.], nsteps=3, rhs="increment")


def cpgimp_finite_plastic_ghost_pressure():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points,
                    VonMises(1e4, .3, yield_stress=12.), bottom,
                    body_force=[0., -20.], loads=[Pressure(
                        side_points(points, "top"), "top", 12.)],
                    nsteps=3, method="cpgimp", kinematics="finite",
                    ghost=.1)


def ugimp_finite_two_bodies():
    mesh, lower = block(region=lambda x: (x[0] < 2) & (x[1] < .9))
    _, upper = block(region=lambda x: (x[0] < 2) & (x[1] > .9)
                     & (x[1] < 1.3))
    upper.body[:] = 1
    points = concatenate_points([lower, upper])
    points.force[:, np.argsort(-points.x[1])[:2]] = [[10.], [-5.]]
    return simulate(mesh, ElementQuad1(), points,
                    [LinearElastic(1e4, .3), LinearElastic(3e4, .25)],
                    bottom, body_force=[0., -20.], nsteps=2,
                    method="ugimp", kinematics="finite")


def fem_finite_antilocking():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e4, .49),
                    bottom, body_force=[0., -200.], nsteps=2, method="fem",
                    kinematics="finite", antilocking=True)


def mpm_finite_modified_antilocking_plastic():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points,
                    VonMises(1e4, .3, yield_stress=20.), bottom,
                    body_force=[0., -30.], nsteps=3, kinematics="finite",
                    antilocking=True, newton="modified")


def prescribed_predictor_armijo():
    mesh, points = block(top=1.)
    under = np.flatnonzero(np.isclose(mesh.p[1], 1.) & (mesh.p[0] <= .5))

    def pushed(b, f_old, f_new):
        return b.nodal_dofs[1, under], np.full(under.size, -.05 * (
            f_new - f_old))
    return simulate(mesh, ElementQuad1(), points,
                    VonMises(1e4, .3, yield_stress=100.), bottom,
                    prescribed=pushed, nsteps=3, kinematics="finite",
                    line_search="armijo")


def rigid_footing_small():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1.5, 7))
    soil = seed_points(mesh, 2, region=lambda x: x[1] < 1.)
    foot = seed_points(mesh, 2, region=lambda x: (x[1] > 1.) & (x[1] < 1.25)
                       & (x[0] < .5))
    foot.body[:] = 1
    points = concatenate_points([soil, foot])
    return simulate(mesh, ElementQuad1(), points,
                    [VonMises(1e4, .3, yield_stress=100.),
                     LinearElastic(1e6, .3)], bottom,
                    rigid_bodies=[RigidBody(1, [0., -.02])], nsteps=3)


def dynamic_newmark_finite_pressure():
    mesh, points = block()
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e4, .3),
                    bottom, body_force=[0., -20.], loads=[Pressure(
                        side_points(points, "top"), "top", 5.)],
                    kinematics="finite",
                    dynamics=Dynamics(.01, .03, 10.))


def dynamic_alpha_cpgimp_ghost():
    mesh, points = block()
    points.velocity = np.zeros_like(points.x)
    points.velocity[0] = .5
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e4, .3),
                    bottom, body_force=[0., -20.], method="cpgimp", ghost=.1,
                    dynamics=Dynamics(.01, .03, 10., scheme=GeneralizedAlpha(
                        .5)))


def hex_mpm_finite():
    mesh = MeshHex.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3),
                               np.linspace(0, 1.5, 4))
    points = seed_points(mesh, 2, region=lambda x: x[2] < 1.)
    return simulate(mesh, ElementHex1(), points, LinearElastic(1e4, .3),
                    lambda b: b.get_dofs(lambda x: x[2] == 0),
                    body_force=[0., 0., -100.], nsteps=2,
                    kinematics="finite")


def hex_cpgimp_small_plastic():
    mesh = MeshHex.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3),
                               np.linspace(0, 1.5, 4))
    points = seed_points(mesh, 2, region=lambda x: x[2] < .8)
    return simulate(mesh, ElementHex1(), points,
                    VonMises(1e4, .3, yield_stress=25.),
                    lambda b: b.get_dofs(lambda x: x[2] == 0),
                    body_force=[0., 0., -100.], nsteps=2, method="cpgimp")


def ghost_auto_switched_on():
    """The ladder's ghost rung: a solver refusing a trial tangent, its
    line-search retry and the stabilised retry of that."""
    from scipy.sparse.linalg import spsolve
    from skfem_mpm import SingularSystemError
    mesh, points = block(top=.76)
    calls = []

    def refusing(A, b, **kwargs):
        calls.append(A.shape[0])
        if len(calls) in (2, 3, 4, 5):
            raise SingularSystemError("a singular trial tangent")
        return spsolve(A.tocsc(), b)
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e3, .3),
                    bottom, body_force=[0., -30.], nsteps=2,
                    kinematics="finite", solver=refusing)


CASES = {f.__name__: f for f in (
    linear_traction, linear_increment, cpgimp_finite_plastic_ghost_pressure,
    ugimp_finite_two_bodies, fem_finite_antilocking,
    mpm_finite_modified_antilocking_plastic, prescribed_predictor_armijo,
    rigid_footing_small, dynamic_newmark_finite_pressure,
    dynamic_alpha_cpgimp_ghost, hex_mpm_finite, hex_cpgimp_small_plastic,
    ghost_auto_switched_on)}


def arrays(result):
    """Every array of a result's points and history, by name."""
    p = result.points
    out = {name: getattr(p, name) for name in (
        "x", "stress", "strain", "volume", "displacement", "domain",
        "velocity", "acceleration", "F")
        if getattr(p, name, None) is not None}
    for name in sorted(p.state):
        out["state." + name] = p.state[name]
    for k, r in enumerate(result.history):
        out["step{}.scalars".format(k)] = np.array(
            [r.load_factor, r.residual, r.increment, r.n_free_dofs])
        if r.newton_residuals is not None:
            out["step{}.newton".format(k)] = np.array(r.newton_residuals)
        out["step{}.reactions".format(k)] = np.asarray(r.reaction_values)
        for j, force in enumerate(r.rigid_forces):
            out["step{}.rigid{}".format(k, j)] = force
        if r.energy is not None:
            out["step{}.energy".format(k)] = np.array(
                [r.energy[key] for key in sorted(r.energy)
                 if key != "contact_work"])
            # booked apart since 2026-11-29: zero without grid terms, whose
            # runs keep their fingerprints
            if r.energy.get("contact_work", 0.) != 0.:
                out["step{}.contact_work".format(k)] = np.array(
                    [r.energy["contact_work"]])
    out["counters"] = np.array([result.counters[key]
                                for key in sorted(result.counters)],
                               dtype=float)
    return out


def fingerprint(result) -> dict:
    """A SHA-256 of the bits of every array, and each array's sum of
    absolute values (to say how far apart two runs are)."""
    digest, sums = hashlib.sha256(), {}
    for name, value in arrays(result).items():
        value = np.ascontiguousarray(value, dtype=np.float64)
        digest.update(name.encode())
        digest.update(value.tobytes())
        sums[name] = float(np.abs(value).sum())
    return {"sha256": digest.hexdigest(), "sums": sums}


def versions() -> dict:
    """What decides the fingerprints' bits: the numerical libraries'
    versions and the CPU features numpy detects.  The features choose
    numpy's SIMD loops (``__cpu_dispatch__``: a sum over AVX-512 lanes
    rounds otherwise than over AVX2's) and OpenBLAS's kernels for the
    CPU (numpy's and scipy's bundled OpenBLAS are built for every
    architecture and pick one as they load).  The cases are the numpy
    path's and their systems small enough for SuperLU: neither numba nor
    MKL (Pardiso) computes any of their numbers."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:                 # numpy 1
        from numpy.core import _multiarray_umath as umath
    return {"numpy": np.__version__, "scipy": scipy.__version__,
            "scikit-fem": skfem.__version__,
            "cpu": sorted(feature for feature, present in
                          umath.__cpu_features__.items() if present),
            "openblas": [openblas_core(module) for module in (np, scipy)]}


def openblas_core(module) -> str:
    """The kernels' family the OpenBLAS bundled with ``module`` (numpy's
    or scipy's wheel, ``<name>.libs``) chose for this CPU, or
    ``"unknown"``: CPUs of the same features may take other families
    (an AMD EPYC with AVX-512 took Haswell's, where the fingerprints'
    Intel CPU of the same features had taken others, and all 13 cases
    differed in their last bits)."""
    folder = Path(module.__file__).parent.parent / (module.__name__
                                                    + ".libs")
    for lib in sorted(folder.glob("*openblas*")):
        library = ctypes.CDLL(str(lib))
        for symbol in ("scipy_openblas_get_corename64_",
                       "scipy_openblas_get_corename",
                       "openblas_get_corename64_", "openblas_get_corename"):
            corename = getattr(library, symbol, None)
            if corename is not None:
                corename.restype = ctypes.c_char_p
                return corename().decode()
    return "unknown"


if __name__ == "__main__":
    json.dump({"versions": versions(), "cases": {
        name: fingerprint(case()) for name, case in CASES.items()}},
        sys.stdout, indent=1, sort_keys=True)
