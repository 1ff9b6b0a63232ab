"""The load-step core computes today what it computed before it was split
into a step problem, a Newton driver and grid terms: bit for bit where the
numerical libraries are the versions the fingerprints were taken with
on a CPU of the same features whose OpenBLAS chose the same kernels
(``tests/data/core_digests.json``: the versions, the features and
OpenBLAS's choice, :func:`digest_cases.versions`), to 1e-12 of
every array's size where they are not (another numpy may round a sum
differently; so does the same numpy where it dispatches to other SIMD
loops: on a CPU with AVX-512 all 13 cases recorded with these
versions differed in their last bits, sums by up to 3e-16 relative in
the arrays and 7e-15 in a Newton history's residuals).

Re-recorded on purpose, with the commit that changed them:
cpgimp_finite_plastic_ghost_pressure when GIMP's surface loads began to
act on the faces of the points' domains, by GIMP's weights there (the
sums moved by up to 1.4e-5), and with it every case, the CPU's features
now in the key (the other cases' sums moved by at most 7e-15);
fem_finite_antilocking and mpm_finite_modified_antilocking_plastic when
mean dilatation began to replace the volumetric part of the 3x3 gradient
in plane strain as in 3D (displacements moved 0.6%); every case's hash
when the counters gained ``line_search_from_step`` (a 0 more in each
counters array, every sum unchanged to the bit);
dynamic_newmark_finite_pressure when the mass began to be added within
the stiffness's pattern, its explicit zeros kept
(``add_within``): the direct solver orders the kept pattern otherwise,
and the sums moved in their last bit or two (2e-16 relative);
ghost_auto_switched_on when the retry ladder put the line search before
the ghost penalty (which changes the step's equations): the solver now
refuses four systems, so that the line search and its stabilised solve
fail before the penalty is switched on, as the case is named for;
cpgimp_finite_plastic_ghost_pressure, dynamic_alpha_cpgimp_ghost and
ghost_auto_switched_on when a cell filled to exactly one half (the
blocks' top rows, 2 x 2 points) stopped being cut or not by round-off
in the points' volumes (it is full; sums moved by up to 3.5e-2 in a
Newton history, 1.4e-3 in the strains); the five small-strain cases'
hashes when the points began to keep their rotation
(``state.rotation``; every other sum unchanged to the bit);
fem_finite_antilocking when finite elements in finite deformation began
to average the increment's spatial divergence ``tr(grad_X(du)
F_n^-1)`` (its second step: the displacement sum moved 1.1e-4).  The
contact's work booked apart in dynamics (``contact_work``, 2026-11-29)
is kept in its own array where it is not zero: every case's arrays
unchanged to the bit.  linear_traction when standard MPM in small strain
began to load its faces at their reference positions along their axis
(the stress sum moved 3.5e-4 relative).  Every case re-recorded, its
arrays unchanged to 4.6e-15 relative, when OpenBLAS's choice of kernels
joined the key (2026-11-30: an AMD EPYC of the recorded features, its
OpenBLAS on Haswell's kernels, differed in the last bits of all 13)."""
import json
from pathlib import Path

import pytest

from digest_cases import CASES, fingerprint, versions
from skfem_mpm.mechanics import kinematics

STORED = json.loads((Path(__file__).parent / "data"
                     / "core_digests.json").read_text())


@pytest.fixture(autouse=True)
def numpy_path(monkeypatch):
    """The fingerprints are the numpy path's, the reference: the compiled
    passes (``kernels="auto"``, the default) round sums in another order,
    and are held to the fingerprints at 1e-12 in ``test_compiled.py``."""
    monkeypatch.setattr(kinematics, "compiled_path",
                        lambda *args, **kwargs: None)


def test_every_stored_case_is_run():
    assert sorted(STORED["cases"]) == sorted(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_run_unchanged(name):
    stored, now = STORED["cases"][name], fingerprint(CASES[name]())
    assert sorted(now["sums"]) == sorted(stored["sums"])
    if versions() == STORED["versions"]:
        assert now["sha256"] == stored["sha256"], {
            key: (now["sums"][key], stored["sums"][key])
            for key in now["sums"] if now["sums"][key] != stored["sums"][key]}
    for key, value in stored["sums"].items():
        assert now["sums"][key] == pytest.approx(value, rel=1e-12,
                                                 abs=1e-300), key
