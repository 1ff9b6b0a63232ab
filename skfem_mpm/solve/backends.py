"""Linear solver back ends behind scikit-fem's ``solver=`` hook.

Each factory returns ``f(A, b, **kwargs) -> x``, with a ``factorise(A)``
attribute returning ``solve(b)`` that reuses the factorisation (modified
Newton, :func:`factorised`):

- :func:`solver_direct_checked`: scipy's SuperLU in symmetric mode, which
  refuses singular systems;
- :func:`solver_pypardiso`: Intel MKL Pardiso through pypardiso (optional),
  symmetric positive definite mode where the matrix is, general otherwise,
  with MKL's reproducible mode (identical runs agree bit for bit,
  :func:`mkl_environment`); a
  factorisation that had to perturb a pivot (a singular matrix) is handed
  to the checked SuperLU, which refuses it or solves it exactly;
- :func:`solver_pyamg`: smoothed-aggregation algebraic multigrid with the
  rigid-body modes as near-null space, conjugate gradients (optional), for
  systems a direct factorisation does not fit; a system on which it
  stalls above its tolerance is solved directly, with a log line;
- ``"auto"`` (the default, :func:`solver_auto`): per system, the back end
  measured fastest for its size and structure among those installed
  (:func:`solver_direct_auto`: SuperLU for a banded system, a thin column).

The sizes from which each back end is the fastest, and what the choice
costs, are measured in ``benchmarks/README.md`` (``benchmarks/solvers.py``,
``benchmarks/solver_structure.py``).

"""
import functools
import hashlib
import importlib.util
import logging
import warnings
import weakref
from typing import Callable, Union

import numpy as np
from numpy import ndarray
from scipy.sparse import csc_matrix, csr_matrix, triu
from scipy.sparse.linalg import splu

from ..errors import InvalidInputError, SingularSystemError
from ..methods.assembly import PatternMatrices, compressed_matrix
from ..quadrature.basis import compiled_kernels
from ..spelling import setting

logger = logging.getLogger(__name__)

__all__ = ["solver_direct_checked", "solver_pypardiso", "solver_pyamg",
           "solver_auto", "solver_direct_auto", "get_solver",
           "available_solvers", "factorised", "rcm_bandwidth",
           "AUTO_PARDISO_FROM", "AUTO_SUPERLU_BANDED", "AUTO_AMG_FROM"]

#: free DOFs from which ``"auto"`` takes Pardiso rather than SuperLU, per
#: dimension of the grid (where they cost the same, measured; in 1D the
#: tridiagonal systems factorise without fill: SuperLU at any size)
AUTO_PARDISO_FROM = {1: float("inf"), 2: 2000, 3: 1000}
#: ``(bandwidth, free DOFs)``: below these free DOFs, a system whose
#: bandwidth after a reverse Cuthill-McKee ordering is at most this many
#: DOFs stays with SuperLU beyond :data:`AUTO_PARDISO_FROM`, per dimension
#: of the grid (a 2D column one to three cells wide, a 3D column one cell
#: across on rollers; measured in ``benchmarks/README.md``)
AUTO_SUPERLU_BANDED = {2: (12, 30_000), 3: (8, 3000)}
#: free DOFs from which ``"auto"`` takes AMG-CG rather than a direct
#: factorisation: in 3D without Pardiso (SuperLU's fill), and beyond
#: direct factorisations' memory
AUTO_AMG_FROM = {"scipy (SuperLU)": {1: 1_500_000, 2: 1_500_000, 3: 5000},
                 "pypardiso": {1: 1_500_000, 2: 1_500_000, 3: 1_500_000}}
#: nonzeros of Pardiso's factor (its analysis, iparm(18)) up to which a
#: factorisation that perturbed a pivot goes to the checked SuperLU; beyond,
#: Pardiso solves it with iterative refinement and the growth check.
#: Measured on 2 cores (elastic stiffness of a cube): SuperLU takes 0.3 s
#: at a fill of 2.5e6 (4752 DOFs), 2.0 s at 1.1e7 (13872 DOFs); on an
#: indefinite tangent its threshold pivoting grows the
#: fill past the estimate: a 3D footing's collapsing step of 12152 DOFs
#: (Pardiso's fill about 1e7) took 56-79 s a factorisation, 400 s silent
HANDOVER_FILL = 3_000_000
#: iterative refinement steps of a Pardiso solve after a perturbed pivot
REFINEMENT_STEPS = 3
#: the smallest normal float
TINY = float(np.finfo(float).tiny)
CAUSES = ("points leave a zero-energy mode (a grid node supported by too few "
          "points: {} ties such nodes to their neighbours, and with "
          "B-splines and no contacts between bodies extended_splines = "
          "true folds them) or the grid has rigid-body modes (missing "
          "supports)".format(setting("ghost", 0.1)))


def same_array(a: ndarray, b: ndarray) -> bool:
    """Whether ``b`` is ``a`` or a view of all of ``a``'s memory, alike
    (scipy's sparse constructors view the index arrays they are given):
    while ``a`` is alive, its memory holds what it held, unless written
    in place."""
    return a is b or (a.shape == b.shape and a.strides == b.strides
                      and a.dtype == b.dtype
                      and a.__array_interface__["data"][0]
                      == b.__array_interface__["data"][0])


def csc_converter() -> Callable:
    """``to_csc(A)``: the CSC matrix of ``A``, entry for entry
    ``A.tocsc()``'s.  A CSR matrix on the index arrays of the last one
    converted (the condensed tangents of a load step's Newton iterations
    share them) takes its entries through the permutation stored then
    (on the seed's column, 22 us an iteration for ``tocsc``'s 44 at 512
    free DOFs, 41 for 78 at 2048).

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> to_csc = csc_converter()
    >>> A = csr_matrix(np.array([[2., 1.], [0., 3.]]))
    >>> bool((to_csc(A) != A.tocsc()).nnz == 0)
    True
    >>> A.data *= 2.                     # the next iteration, same pattern
    >>> to_csc(A).toarray().tolist()
    [[4.0, 2.0], [0.0, 6.0]]
    """
    last = []              # one pattern: (indices, indptr, shape, csc parts)
    matrices = PatternMatrices(csc_matrix)

    def to_csc(A):
        if getattr(A, "format", None) != "csr":
            return A.tocsc()
        if not (last and same_array(last[0], A.indices)
                and same_array(last[1], A.indptr) and last[2] == A.shape):
            numbers = compressed_matrix(
                csr_matrix, np.arange(A.nnz, dtype=np.float64), A.indices,
                A.indptr, A.shape).tocsc()
            # the places of the diagonal in the CSC data, where all of it
            # is in the pattern (else None: scipy's diagonal)
            places = compressed_matrix(
                csc_matrix, np.arange(1., A.nnz + 1.), numbers.indices,
                numbers.indptr, A.shape).diagonal()
            last[:] = (A.indices, A.indptr, A.shape,
                       numbers.data.astype(np.int64), numbers.indices,
                       numbers.indptr, places.astype(np.int64) - 1
                       if places.all() else None)
        take, indices, indptr = last[3:6]
        C = matrices(A.data[take], indices, indptr, A.shape)
        last[7:] = [C.indices, C.indptr]        # scipy's views of them
        return C

    def diagonal(C):
        """The diagonal of a matrix ``to_csc`` returned (its entries at
        the places kept for the pattern: 7 us at 28 DOFs for scipy's)."""
        if last and last[6] is not None and C.indices is last[7] \
                and C.indptr is last[8]:
            return C.data[last[6]]
        return C.diagonal()
    to_csc.diagonal = diagonal
    return to_csc


def solver_direct_checked(pivot_tol: float = 1e-9,
                          growth_tol: float = 1e12) -> Callable:
    """scipy's sparse LU (SuperLU, symmetric mode) as a scikit-fem solver
    ``f(A, b) -> x`` that refuses singular systems.

    A solution that grows beyond ``growth_tol`` times ``|b| / max|A_ii|``
    is examined: each pivot is compared with the diagonal entry of the
    (permuted) matrix it eliminates.  A zero-energy mode leaves a pivot at
    round-off level of its diagonal (1e-12 and below), while grid nodes
    that points support only weakly have small diagonals *and* small
    pivots, a ratio of order one.  A ratio below ``pivot_tol`` raises
    :class:`~skfem_mpm.errors.SingularSystemError`.

    ``solver.factorise(A)`` returns ``solve(b)``, which reuses the
    factorisation for any number of right-hand sides (modified Newton).

    """
    to_csc = csc_converter()

    def factorise(A, **kwargs):
        A = to_csc(A)
        try:
            lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=.1,
                      options=dict(SymmetricMode=True))
        except RuntimeError as err:
            raise SingularSystemError("the stiffness on {} free DOFs is "
                                      "singular ({}): {}".format(
                                          A.shape[0], err, CAUSES)) from err
        diagonal = max(np.abs(to_csc.diagonal(A)).max(), TINY)

        def solve(b):
            x = lu.solve(b)
            largest = np.abs(x).max()        # not finite: inf or nan
            if largest < np.inf and largest <= \
                    growth_tol * np.abs(b).max() / diagonal:
                return x
            check_pivots(A, lu, x)
            return x
        return solve

    def check_pivots(A, lu, x):
        n = A.shape[0]
        rows, cols = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
        rows[lu.perm_r], cols[lu.perm_c] = np.arange(n), np.arange(n)
        pivoted = np.abs(np.asarray(A[rows, cols]).ravel())
        with np.errstate(divide="ignore", over="ignore"):
            # an off-diagonal pivot (zero diagonal entry) counts as regular
            ratio = np.abs(lu.U.diagonal()) / pivoted
        worst = int(np.argmin(ratio))
        if not ratio[worst] >= pivot_tol or not np.all(np.isfinite(x)):
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular: a pivot is {:.1e} "
                "of its diagonal entry (below {:.0e}), at condensed DOF {}; "
                "{}".format(n, ratio[worst], pivot_tol, cols[worst], CAUSES))

    def solver(A, b, **kwargs):
        return factorise(A)(b)

    solver.factorise = factorise
    return solver


#: entries of a matrix compared with their mirrors at a time
#: (:func:`is_symmetric`): three temporaries of 8 bytes an entry, 24 MB at
#: 2 ** 20 entries, were the peak of the heap of a 3D block of 3.3e4
#: points (486 bytes a point)
SYMMETRY_BLOCK = 1 << 16


def is_symmetric(A, rtol: float = 1e-12) -> bool:
    """Whether the sparse matrix ``A`` equals its transpose to ``rtol`` of
    its largest entry (tangents of non-associated plasticity are not).

    A CSR matrix whose pattern is symmetric is compared with its mirror
    entries (in a canonical copy where it is not canonical: sorted,
    duplicates summed): by one compiled pass where numba imports and
    ``SKFEM_MPM_KERNELS`` is not ``numpy``
    (:func:`~skfem_mpm.kernels.graph.symmetric_deviation`, the same
    largest difference), else in blocks of :data:`SYMMETRY_BLOCK` entries
    (:func:`mirror_positions`; a pattern of more than
    :data:`MIRRORS_KEPT` entries by :func:`mirrored_blocks`, its mirror
    positions not kept), without forming ``A - A.T``: two more matrices at
    the peak of a factorisation, 1.8 kB per point of a 3D run.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> from skfem_mpm.solve.backends import is_symmetric
    >>> A = np.array([[2., 1.], [1., 3.]])
    >>> is_symmetric(csr_matrix(A)), is_symmetric(csr_matrix(A + [[0, 1e-9],
    ...                                                              [0, 0]]))
    (True, False)
    """
    if A.shape[0] != A.shape[1]:
        return False
    if A.format == "csr" and not A.has_canonical_format:
        A = A.copy()              # its index arrays may be another's too
        A.sum_duplicates()
    graph = compiled_kernels("graph") if A.format == "csr" else None
    if graph is not None:         # the same differences, in one pass
        status, largest = graph.symmetric_deviation(A.indptr, A.indices,
                                                    A.data)
        if status == 0:
            return bool(A.nnz == 0 or largest <= rtol * max(A.data.max(),
                                                            -A.data.min()))
    if A.format == "csr":
        data, largest = A.data, 0.
        if A.nnz <= MIRRORS_KEPT:
            mirror = mirror_positions(A)
            pairs = [None] if mirror is None else (
                (slice(s, s + SYMMETRY_BLOCK), mirror[s:s + SYMMETRY_BLOCK])
                for s in range(0, A.nnz, SYMMETRY_BLOCK))
        else:
            pairs = mirrored_blocks(A)
        for pair in pairs:
            if pair is None:                 # the pattern is not symmetric
                break
            if pair[1].size:
                largest = max(largest, np.abs(data[pair[0]]
                                              - data[pair[1]]).max())
        else:
            return bool(A.nnz == 0 or largest <= rtol * max(data.max(),
                                                            -data.min()))
    # a pattern made asymmetric by dropped zeros (sums of sparse products):
    # the difference formed for blocks of rows, against the transpose
    A, T = A.tocsr(), A.T.tocsr()
    largest, rows = 0., max(1, (1 << 18) * A.shape[0] // max(A.nnz, 1))
    for s in range(0, A.shape[0], rows):
        difference = A[s:s + rows] - T[s:s + rows]
        if difference.nnz:
            largest = max(largest, np.abs(difference.data).max())
    return bool(A.nnz == 0 or largest <= rtol * abs(A).max())


#: entries of a matrix whose rows :func:`upper_triangle` finds at a time
TRIANGLE_BLOCK = 1 << 16


def upper_triangle(A) -> csr_matrix:
    """The upper triangle of ``A`` (diagonal included) as CSR with sorted
    indices; from a canonical CSR matrix by a mask on its entries, without
    scipy's detour through COO (16 bytes an entry more at the peak of a
    Pardiso factorisation), or where numba imports and
    ``SKFEM_MPM_KERNELS`` is not ``numpy`` by one compiled pass
    (:func:`~skfem_mpm.kernels.graph.upper_entries`: the same arrays,
    without the mask).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> from skfem_mpm.solve.backends import upper_triangle
    >>> upper_triangle(csr_matrix(np.arange(1., 10.).reshape(3, 3))).toarray()
    array([[1., 2., 3.],
           [0., 5., 6.],
           [0., 0., 9.]])
    """
    if not (A.format == "csr" and A.has_canonical_format):
        upper = triu(A, format="csr")
        upper.sort_indices()
        return upper
    graph = compiled_kernels("graph")
    if graph is not None:           # the same entries, without the mask
        return csr_matrix(graph.upper_entries(A.indptr, A.indices, A.data),
                          shape=A.shape)
    n, index, indptr = A.shape[0], A.indices.dtype, A.indptr
    # the entries' rows and the kept ones' count by row for rows of about
    # TRIANGLE_BLOCK entries at a time: the rows of all entries and a
    # running count of the kept ones were 8 bytes an entry at the peak of
    # a Pardiso factorisation (250 bytes a point in 3D)
    keep = np.empty(A.nnz, dtype=bool)
    starts = np.zeros(n + 1, dtype=indptr.dtype)
    step = max(1, TRIANGLE_BLOCK * n // max(A.nnz, 1))
    for first in range(0, n, step):
        last = min(first + step, n)
        lo, hi = indptr[first], indptr[last]
        counts = np.diff(indptr[first:last + 1])
        rows = np.repeat(np.arange(first, last, dtype=index), counts)
        np.greater_equal(A.indices[lo:hi], rows, out=keep[lo:hi])
        starts[first + 1:last + 1] = np.bincount(
            rows[keep[lo:hi]] - first, minlength=last - first)
    np.cumsum(starts, out=starts)
    return csr_matrix((A.data[keep], A.indices[keep], starts), shape=A.shape)


MIRRORS = {}          # the last pattern's mirror positions (one entry)
BANDS = {}            # the last pattern's bandwidth (one entry)


def kept_for_pattern(store: dict, A, compute: Callable):
    """``compute(A)`` for the CSR matrix ``A``, a function of its pattern
    only, kept in ``store`` for the last pattern while the memory of its
    index arrays lives (the condensed tangents of a load step share it);
    index arrays changed in place would not be noticed."""
    key = (memory_of(A.indices), memory_of(A.indptr))
    cached = store.get("last")
    if cached is not None and all(
            ref() is owner and where == place
            for (ref, where), (owner, place) in zip(cached[0], key)):
        return cached[1]
    value = compute(A)

    def forget(ref):
        entry = store.get("last")
        if entry is not None and any(ref is r for r, _ in entry[0]):
            store.clear()
    store["last"] = (tuple((weakref.ref(owner, forget), place)
                           for owner, place in key), value)
    return value


#: entries of a pattern (rows of about so many) whose mirror positions
#: :func:`mirrored_blocks` finds at a time
MIRROR_BLOCK = 1 << 16
#: entries of the largest pattern whose mirror positions :func:`is_symmetric`
#: forms whole and keeps (:func:`mirror_positions`: 4 bytes an entry kept,
#: 8 more while they are formed); a larger one's are found again at each
#: call, a block of rows at a time (:func:`mirrored_blocks`): kept, they
#: were 124 bytes a point at every peak of a 3D run's heap after the first
#: factorisation (1.1e5 points), and formed whole 248 at that one, where
#: finding them costs 50-65 ms an iteration at 3.5e6 entries (the
#: comparison with kept ones 25-30; the iteration 2.1 s)
MIRRORS_KEPT = 1 << 20


def mirrored_blocks(A):
    """For a canonical square CSR matrix ``A``, pairs ``(entries,
    mirrors)`` of index arrays into ``A.data``: the entries of rows of
    about :data:`MIRROR_BLOCK` entries, and those at their mirrored places
    (``(j, i)`` for ``(i, j)``); every entry is in one pair.  A None pair
    (the last) where the pattern turns out not to be symmetric.

    The transpose of a block of rows' entry numbers places the block's
    entries of each column after the earlier blocks' in the column's
    mirror, the row of the same number; no array of all entries is made
    but the check of the column counts against the rows' (ints of the
    size of a row).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> from skfem_mpm.solve.backends import mirrored_blocks
    >>> A = csr_matrix(np.array([[1., 2.], [3., 4.]]))
    >>> [(e.tolist(), m.tolist()) for e, m in mirrored_blocks(A)]
    [([0, 2, 1, 3], [0, 1, 2, 3])]
    """
    n, indptr, indices = A.shape[0], A.indptr, A.indices
    # the transpose's rows are as long as A's (its columns as full)
    if not np.array_equal(np.bincount(indices, minlength=n),
                          np.diff(indptr)):
        yield None
        return
    place = indptr[:-1].copy()        # the next place in each column's row
    step = max(1, MIRROR_BLOCK * n // max(A.nnz, 1))
    for first in range(0, n, step):
        last = min(first + step, n)
        lo, hi = indptr[first], indptr[last]
        block = csr_matrix((np.arange(lo, hi, dtype=indices.dtype),
                            indices[lo:hi], indptr[first:last + 1] - lo),
                           shape=(last - first, A.shape[1])).tocsc()
        counts = np.diff(block.indptr)
        places = np.repeat(place - block.indptr[:-1], counts)
        places += np.arange(block.nnz, dtype=places.dtype)
        # the entries there have the rows as columns: the pattern is
        # symmetric so far
        block.indices += first
        if not np.array_equal(indices[places], block.indices):
            yield None
            return
        yield block.data, places
        place += counts


def mirror_positions(A):
    """For a canonical CSR matrix ``A`` with a symmetric pattern, the index
    in ``A.data`` of the entry at the mirrored place, ``(j, i)`` for
    ``(i, j)``; None where the pattern is not symmetric.  Kept for the last
    pattern (:func:`kept_for_pattern`), as 4 bytes an entry.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> from skfem_mpm.solve.backends import mirror_positions
    >>> A = csr_matrix(np.array([[1., 2.], [3., 4.]]))
    >>> mirror_positions(A).tolist()
    [0, 2, 1, 3]
    """
    def compute(A):
        numbers = csr_matrix((np.arange(A.nnz, dtype=A.indices.dtype),
                              A.indices, A.indptr), shape=A.shape)
        transposed = numbers.T.tocsr()
        return transposed.data if (
            np.array_equal(transposed.indptr, A.indptr)
            and np.array_equal(transposed.indices, A.indices)) else None
    return kept_for_pattern(MIRRORS, A, compute)


def rcm_bandwidth(A) -> int:
    """The bandwidth of the square sparse matrix ``A`` after a reverse
    Cuthill-McKee ordering of its pattern (taken as symmetric): the
    largest ``|i - j|`` of an entry, in DOFs; for a CSR matrix kept for
    the last pattern (:func:`kept_for_pattern`).  One breadth-first pass
    over the pattern: 0.5 ms at 4e3 free DOFs, 29 ms at 1.3e5 (2D).

    Examples
    --------
    >>> from scipy.sparse import diags
    >>> from skfem_mpm.solve.backends import rcm_bandwidth
    >>> rcm_bandwidth(diags([1., 2., 1.], [-1, 0, 1], shape=(50, 50)))
    1
    """
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    def compute(A):
        n = A.shape[0]
        if A.nnz == 0:
            return 0
        order = reverse_cuthill_mckee(A, symmetric_mode=True)
        place = np.empty(n, dtype=np.int64)
        place[order] = np.arange(n)
        rows = place[np.repeat(np.arange(n), np.diff(A.indptr))]
        return int(np.abs(rows - place[A.indices]).max())
    if A.format != "csr":
        return compute(A.tocsr())
    return kept_for_pattern(BANDS, A, compute)


def memory_of(array: ndarray):
    """``(owner, place)``: the array owning the memory of ``array`` and
    where in it ``array`` lies (address, shape, strides, type), so that
    views of one index array (scipy makes one at every matrix it builds
    from given arrays) are known as the same."""
    owner = array
    while isinstance(owner.base, np.ndarray):
        owner = owner.base
    return owner, (array.__array_interface__["data"][0], array.shape,
                   array.strides, array.dtype.str)


def pattern_digest(A) -> bytes:
    """The SHA-256 digest of a CSR matrix's shape, index types and index
    arrays: equal for equal patterns (of the same index types)."""
    digest = hashlib.sha256(repr((A.shape, A.indptr.dtype.str,
                                  A.indices.dtype.str)).encode())
    digest.update(np.ascontiguousarray(A.indptr))
    digest.update(np.ascontiguousarray(A.indices[:A.indptr[-1]]))
    return digest.digest()


def pattern_of(A) -> dict:
    """The sparsity pattern of a CSR matrix, as the digest of its index
    arrays (:func:`pattern_digest`): copies of them, held by a back end
    between iterations, were 65 bytes a point of a 3D run's heap (Pardiso's
    analysed triangle); the digest takes 4.6 ms for 1.8e6 entries where
    comparing them took 0.4 (a 3D run's solve of them 2.1 s an iteration).

    >>> from scipy.sparse import identity
    >>> same_pattern(identity(3, format="csr"),
    ...              pattern_of(2 * identity(3, format="csr")))
    True
    >>> same_pattern(identity(4, format="csr"),
    ...              pattern_of(identity(3, format="csr")))
    False
    """
    return {"digest": pattern_digest(A)}


def same_pattern(A, pattern: dict) -> bool:
    """``A`` has the sparsity pattern ``pattern`` (:func:`pattern_of`)."""
    return bool(pattern) and pattern["digest"] == pattern_digest(A)


def mkl_environment():
    """Settings MKL reads from the environment at its first computation in
    the process (each unless the environment says otherwise; they stay set
    for the process and its children):

    - ``MKL_CBWR=AUTO,STRICT``, conditional numerical reproducibility:
      without it Pardiso's threads round differently from run to run
      (1e-16), and a resumed run would not be bit-identical; it costs
      10-15% of Pardiso's time;
    - ``KMP_BLOCKTIME=0``: MKL's threads sleep as soon as a solve ends
      instead of spinning for 200 ms on the cores that the (single
      threaded) point updates between solves share (what spinning cost is
      in ``benchmarks/README.md``; Pardiso's own time is unchanged).

    Where MKL has computed before skfem-mpm's first Pardiso solve (another
    library using MKL), set them in the environment instead."""
    import os
    os.environ.setdefault("MKL_CBWR", "AUTO,STRICT")
    os.environ.setdefault("KMP_BLOCKTIME", "0")


@functools.lru_cache(maxsize=8)
def _installed(module: str) -> bool:
    """Whether the optional package ``module`` is importable, looked up
    once a process: ``importlib.util.find_spec`` searches the path at each
    call for a package not yet imported (50 us; a run's ``solver_auto``
    made seven lookups, 0.4 ms).  Its arguments are the optional back
    ends' names."""
    return importlib.util.find_spec(module) is not None


def _require(module: str, extra: str):
    if not _installed(module):
        raise InvalidInputError(
            "the {} solver needs the optional package {} (pip install "
            "{})".format(extra, module, extra))


def pardiso_solver(mtype: int):
    """A ``pypardiso.PyPardisoSolver`` of matrix type ``mtype`` without
    iterative refinement.  pypardiso
    searches the installation for MKL's library at every creation when
    ``find_library`` does not find it (0.2-1 s on a pip-installed MKL,
    a search its import has made once for its own solver ``pypardiso.ps``):
    that path is kept in ``PYPARDISO_MKL_RT`` for the process, which
    pypardiso reads first (where a pypardiso release no longer names it
    there, each creation searches as before)."""
    import os
    import pypardiso
    found = getattr(getattr(getattr(pypardiso, "ps", None), "libmkl", None),
                    "_name", None)
    if isinstance(found, str) and found:  # what ctypes loaded it from
        os.environ.setdefault("PYPARDISO_MKL_RT", found)
    pardiso = pypardiso.PyPardisoSolver(mtype=mtype)
    # MKL's defaults (iparm(1) = 0) but for iterative refinement, which
    # they run twice in every solve (three times its cost): none here
    # (iparm(8) = 0); a factorisation that perturbed a pivot goes to
    # SuperLU, or beyond HANDOVER_FILL is solved with refinement set per
    # solve; the factorisations are backward stable and solve_active
    # checks the backward error of every solve
    # iparm(35) = 1: the index arrays zero-based, as scipy's
    # (:func:`call_pardiso`)
    general = mtype == 11
    for number, value in ((1, 1), (2, 2), (8, 0), (10, 13 if general else 8),
                          (11, int(general)), (13, int(general)), (18, -1),
                          (19, -1), (35, 1)):
        pardiso.iparm[number - 1] = value
    return pardiso


def call_pardiso(pardiso, A, b: ndarray) -> ndarray:
    """pypardiso's ``_call_pardiso(A, b)`` at the phase set, with the CSR
    index arrays of ``A`` given to MKL as they are, zero-based (iparm(35)
    = 1, :func:`pardiso_solver`): pypardiso copies both to make them
    one-based (int32, then plus one), 130 bytes a point at the peak of a
    3D run's factorisation.  Through pypardiso's MKL binding and state
    (``pt``, ``perm``, ``iparm``, ``msglvl``), as its own call."""
    import ctypes
    from pypardiso.pardiso_wrapper import PyPardisoError
    x = np.zeros_like(b)
    error = ctypes.c_int32(0)
    ints = ctypes.POINTER(ctypes.c_int32)
    floats = ctypes.POINTER(ctypes.c_double)
    ia = np.ascontiguousarray(A.indptr, dtype=np.int32)
    ja = np.ascontiguousarray(A.indices, dtype=np.int32)
    data = np.ascontiguousarray(A.data, dtype=np.float64)

    def integer(value):
        return ctypes.byref(ctypes.c_int32(value))
    pardiso._mkl_pardiso(
        pardiso.pt.ctypes.data_as(ctypes.POINTER(pardiso._pt_type[0])),
        integer(1), integer(1), integer(pardiso.mtype),
        integer(pardiso.phase), integer(A.shape[0]),
        data.ctypes.data_as(floats), ia.ctypes.data_as(ints),
        ja.ctypes.data_as(ints), pardiso.perm.ctypes.data_as(ints),
        integer(1 if b.ndim == 1 else b.shape[1]),
        pardiso.iparm.ctypes.data_as(ints), integer(pardiso.msglvl),
        b.ctypes.data_as(floats), x.ctypes.data_as(floats),
        ctypes.byref(error))
    if error.value != 0:
        raise PyPardisoError(error.value)
    return np.ascontiguousarray(x)


def solver_pypardiso(spd: bool = True, growth_tol: float = 1e12,
                     handover_fill: int = HANDOVER_FILL) -> Callable:
    """MKL Pardiso via pypardiso; ``spd=True`` factorises a symmetric
    matrix's upper triangle as symmetric positive definite (elastic steps)
    and falls back to the general real factorisation for a matrix that is
    not symmetric (non-associated plasticity) or not positive definite;
    ``False`` always factorises as a general real matrix.

    A singular matrix is not refused by Pardiso: the general
    factorisation replaces a zero pivot by a small one, the positive
    definite one keeps a pivot at round-off, and either answers with
    arbitrary multiples of the null vector.  So a factorisation that
    perturbed a pivot, and a solution that grows beyond ``growth_tol``
    times ``|b| / max|A_ii|`` (as in :func:`solver_direct_checked`), go to
    :func:`solver_direct_checked`, which refuses the system or, for a load
    orthogonal to the singular mode, solves it; ``solver.handed_over``
    counts those systems, each kind said once at INFO.  A perturbed
    factorisation whose factor holds more than ``handover_fill`` nonzeros
    (:data:`HANDOVER_FILL`: SuperLU's pivoting took minutes on a 3D
    tangent of 12152 DOFs) is solved by Pardiso itself with
    :data:`REFINEMENT_STEPS` of iterative refinement, a solution that grows
    as above refused as singular (a failed Newton iteration: the step's
    stabilised tangent, retries and cut-backs follow); the caller checks
    every solve's backward error; ``solver.refined`` counts those.

    The returned solver keeps its symbolic analysis (fill-reducing ordering
    and factor structure) and redoes only the numerical factorisation while
    successive matrices share one sparsity pattern and kind, as the Newton
    iterations of a load step do; ``solver.analyses`` counts the analyses.
    ``solver.factorise(A)`` returns ``solve(b)``, reusing the factorisation
    for any number of right-hand sides (modified Newton).
    Its MKL memory is released when the solver is garbage collected (or by
    calling ``solver.release()``).

    """
    _require("pypardiso", "pypardiso")
    mkl_environment()
    from pypardiso.pardiso_wrapper import PyPardisoError

    checked = solver_direct_checked()
    said_already = set()

    def said(level, what, *args):
        """Log once a solver at ``level``, then at DEBUG."""
        logger.log(logging.DEBUG if what in said_already else level, *args)
        said_already.add(what)
    kinds = {}                  # created on first use: see pardiso_solver
    analysed = {True: {}, False: {}}
    indefinite = {}             # the pattern of a matrix that was not SPD
    # per matrix type, a token of the factorisation made last (not the
    # matrix, which lives as long as a solve of it: the 3D block of
    # benchmarks/compiled_cost.py peaked at 3886 bytes a point, 3960 with
    # the matrix kept here)
    factorised = {}

    def factor(A, definite):
        """Analyse (for a new pattern) and factorise: ``(the Pardiso
        object, the matrix it factorised, the factorisation's token)``."""
        if definite not in kinds:
            kinds[definite] = pardiso_solver(2 if definite else 11)
        pardiso, seen = kinds[definite], analysed[definite]
        matrix = upper_triangle(A) if definite else A.tocsr()
        if not matrix.has_sorted_indices:   # a copy: A's arrays may be shared
            matrix = matrix.sorted_indices()
        if not np.diff(matrix.indptr).all():     # Pardiso would crash
            raise SingularSystemError("the stiffness has an empty row")
        same = same_pattern(matrix, seen)
        nothing = np.zeros(matrix.shape[0])
        if not same:
            pardiso.free_memory(everything=True)
            pardiso.set_phase(11)
            call_pardiso(pardiso, matrix, nothing)
            seen.update(pattern_of(matrix))
            solver.analyses += 1
        pardiso.set_phase(22)            # numerical factorisation
        try:
            call_pardiso(pardiso, matrix, nothing)
        except PyPardisoError as err:    # -4: zero pivot (not definite)
            if definite:
                logger.debug("Pardiso: not positive definite (error %s); "
                             "factorising as a general matrix while the "
                             "pattern lasts", err.value)
                indefinite.update(seen)
                seen.clear()
                return factor(A, False)
            seen.clear()
            raise SingularSystemError(
                "Pardiso failed with error {} on {} free DOFs: the "
                "stiffness is singular".format(err.value,
                                               matrix.shape[0])) from err
        token = object()
        factorised[pardiso.mtype] = token
        return pardiso, matrix, token

    def factorise(A, **kwargs):
        definite = spd and is_symmetric(A)
        if definite and indefinite:           # failed before on this pattern
            definite = not same_pattern(upper_triangle(A), indefinite)
        pardiso, matrix, token = factor(A, definite)
        perturbed = int(pardiso.iparm[13])
        fill = int(pardiso.iparm[17])
        refine = bool(perturbed) and fill > handover_fill
        if perturbed:
            # a zero pivot replaced by a small one: Pardiso's answer to a
            # singular matrix (a zero-energy mode) would be garbage along
            # the mode; SuperLU's pivot check refuses it or solves it, where
            # its factorisation is affordable (HANDOVER_FILL); beyond,
            # Pardiso's own with iterative refinement, a solution that
            # grows refused as singular (the step's retries act), and the
            # backward error checked by the caller (solve_active)
            solver.handed_over += 1
            if refine:
                solver.refined += 1
            said(logging.INFO, "refined" if refine else "superlu",
                 "Pardiso perturbed %d pivot(s) of %d free DOFs (a "
                 "zero-energy mode or a tangent that lost its stiffness): "
                 "%s (said once; %d system(s) so far)", perturbed,
                 A.shape[0], "its factor of {:.1e} nonzeros is beyond "
                 "{:.0e} (HANDOVER_FILL), where SuperLU's check can take "
                 "minutes: solved by Pardiso with iterative refinement, a "
                 "solution that grows refused as singular".format(
                     fill, handover_fill) if refine else
                 "solved by the checked SuperLU, which refuses a singular "
                 "system", solver.handed_over)
            if not refine:
                return checked.factorise(A)

        diagonal = max(np.abs(A.diagonal()).max(), np.finfo(float).tiny)
        superlu = {}

        def solve(b):
            if superlu:
                return superlu["solve"](b)
            if factorised.get(pardiso.mtype) is not token:
                # another matrix of this kind was factorised since
                return factorise(A)(b)
            pardiso.set_phase(33)        # forward and back substitution
            pardiso.iparm[7] = REFINEMENT_STEPS if refine else 0
            try:
                x = call_pardiso(pardiso, matrix,
                                 np.asfortranarray(b, dtype=float))
            finally:
                pardiso.iparm[7] = 0
            if np.all(np.isfinite(x)) and np.abs(x).max() <= \
                    growth_tol * np.abs(b).max() / diagonal:
                return x
            if refine or fill > handover_fill:
                # (no pivot perturbed, but a factor beyond HANDOVER_FILL:
                # refused as well, where SuperLU's check can take minutes)
                raise SingularSystemError(
                    "the stiffness on {} free DOFs is singular: {} the "
                    "solution grew to {:.1e}, beyond {:.0e} times the "
                    "loads' {:.1e} over the largest diagonal entry {:.1e}; "
                    "{}".format(
                        A.shape[0], "Pardiso perturbed {} pivot(s) and"
                        .format(perturbed) if refine else "its factor of "
                        "{:.1e} nonzeros is beyond {:.0e} (HANDOVER_FILL, "
                        "SuperLU's check not tried) and".format(
                            fill, handover_fill), np.abs(x).max(),
                        growth_tol, np.abs(b).max(), diagonal, CAUSES))
            # a nearly singular matrix factorised as positive definite
            # (no pivot perturbed, a pivot at round-off instead): SuperLU's
            # pivot check decides, for this matrix from now on
            solver.handed_over += 1
            said(logging.INFO, "grew",
                 "Pardiso's solution grew to %.1e on %d free DOFs: solved "
                 "by the checked SuperLU, which refuses a singular system "
                 "(said once; %d system(s) so far)", np.abs(x).max(),
                 A.shape[0], solver.handed_over)
            superlu["solve"] = checked.factorise(A)
            return superlu["solve"](b)
        return solve

    def solver(A, b, **kwargs):
        return factorise(A)(b)

    solver.factorise = factorise
    # a general matrix's analysis holds a scaling and matching computed from
    # the values of the matrix it analysed (iparm(11), iparm(13)): kept
    # within a load step only, so that a resumed run factorises as the
    # uninterrupted one does
    solver.forget = analysed[False].clear
    solver.analyses = 0
    solver.handed_over = 0      # systems Pardiso perturbed, SuperLU solved
    solver.refined = 0          # of those, solved by Pardiso (refined)
    # MKL's memory goes with the solver function (a finaliser on the Pardiso
    # objects themselves would keep them alive through their own methods)
    solver.release = weakref.finalize(
        solver, lambda: [k.free_memory(everything=True)
                         for k in kinds.values()])
    return solver


def amg_iterate(A, ml, accel: str, b: ndarray, reused: bool, tol: float,
                maxiter: int):
    """Krylov iterations on ``A`` preconditioned by the hierarchy ``ml``
    (built on ``A`` itself, or on an earlier matrix of its pattern):
    ``(x, relative residual, iterations)``, the residual ``|b - A x| /
    |b|`` itself (GMRES stops on the preconditioned one: where that
    has converged and this has not, the iterations go on once from
    ``x``, to a tolerance smaller by the ratio of the two)."""
    import pyamg
    residuals, x = [], None
    scale = max(np.linalg.norm(b), np.finfo(float).tiny)
    goal, count = tol, 0
    for attempt in range(2):
        with warnings.catch_warnings(record=True) as caught:
            # pyamg warns where CG meets an indefinite matrix: the
            # residual check raises instead
            warnings.simplefilter("always")
            try:
                residuals.clear()
                if reused or attempt:
                    x, _ = getattr(pyamg.krylov, accel)(
                        A, b, x0=x, tol=goal,
                        maxiter=min(maxiter, A.shape[0]),
                        M=ml.aspreconditioner(), residuals=residuals)
                else:
                    x = ml.solve(b, tol=goal,
                                 maxiter=min(maxiter, A.shape[0]),
                                 residuals=residuals, accel=accel)
            except (ValueError, ArithmeticError) as err:
                raise SingularSystemError(
                    "pyamg failed on {} free DOFs: {}".format(
                        A.shape[0], err)) from err
        for warning in caught:
            logger.debug("pyamg: %s", str(warning.message).strip())
        count += len(residuals) - 1
        relative = np.linalg.norm(b - A @ x) / scale
        if relative <= tol or not np.isfinite(relative):
            break
        goal = max(goal * tol / relative / 10., 1e-16)
    return x, relative, count


def solver_pyamg(tol: float = 1e-10, maxiter: int = 500,
                 fallback: Union[bool, Callable] = True,
                 dim: int = 2) -> Callable:
    """Smoothed-aggregation AMG preconditioned CG (pyamg; GMRES for a
    matrix that is not symmetric, as the tangents of non-associated
    plasticity), with the rigid-body modes of the free DOFs as near-null
    space when the caller provides them (``modes``).  Logs the iterations.
    ``solver.factorise(A, modes)`` returns ``solve(b)``, which reuses the
    hierarchy for any number of right-hand sides.

    A system on which the iterations end above ``tol`` (judged by the true
    relative residual ``|b - A x| / |b|``) or fail is solved directly:
    conjugate gradients stall where ``tol`` lies below the round-off of an
    ill-conditioned tangent (4.9e-8 on a 3D column of 3.3e4 points; on a
    2D column of 1 x 16384 cells the direct solvers' own solutions leave
    3e-8), diverge on thin columns, and cannot solve a tangent far from
    positive definite.
    The direct back end is the one ``"auto"`` takes for the system
    (:func:`solver_direct_auto`, for a grid of dimension ``dim``), or
    ``fallback``, a solver with ``factorise`` (``"auto"`` hands its own);
    it solves the system or refuses it as singular.  One log line names
    the residual reached and the back end, a warning where the caller
    asked for pyamg (``fallback=True``), at INFO for ``"auto"``; the
    further systems of the pattern are solved directly at once, until
    ``solver.forget()`` (the rest of the load step).  ``solver.fallbacks``
    counts the systems the iterations failed on.  ``fallback=False`` raises
    :class:`~skfem_mpm.errors.SingularSystemError` instead.

    The hierarchy (the setup, about half of an AMG solve's time) is kept
    while successive matrices share one sparsity pattern and near-null
    space, as the Newton iterations of a load step do (``solver.forget()``
    drops it; the load-step core calls it at every step, so that a run
    resumed at a step computes what the uninterrupted one does): a later
    matrix is solved by Krylov iterations on itself, preconditioned by the
    kept hierarchy (``benchmarks/README.md`` has what that saves); a
    hierarchy is built for it where they do not converge, and for the next
    matrix where they took more than twice the iterations of the
    hierarchy's own first solve.  ``solver.hierarchies`` counts the
    hierarchies built.
    """
    _require("pyamg", "pyamg")
    own = fallback is True
    direct = solver_direct_auto(dim, log=False) if own else fallback

    kept = {}           # the last hierarchy and the pattern it was built on

    def hierarchy(A, modes):
        import pyamg
        # pyamg draws from numpy's global generator: a fixed seed, and the
        # caller's generator left where it was (identical runs agree)
        state = np.random.get_state()
        np.random.seed(0)
        try:
            ml = pyamg.smoothed_aggregation_solver(A, B=modes)
        finally:
            np.random.set_state(state)
        kept.clear()
        kept.update(pattern_of(A), ml=ml, modes=modes)
        solver.hierarchies += 1
        return ml

    def iterate(A, chosen, accel, b):
        """``(x, relative residual, iterations)`` by the Krylov
        iterations, on a hierarchy for ``A`` where the kept one does not
        serve."""
        x, relative, count = amg_iterate(A, chosen["ml"], accel, b,
                                         chosen["reused"], tol, maxiter)
        if not relative <= tol and chosen["reused"]:
            # the earlier hierarchy no longer serves: one for A
            logger.debug("pyamg: the kept hierarchy did not converge "
                         "(%.1e); building one for this matrix", relative)
            chosen.update(ml=hierarchy(A, modes=chosen["modes"]),
                          reused=False)
            x, relative, count = amg_iterate(A, chosen["ml"], accel, b,
                                             False, tol, maxiter)
        solver.iterations.append(count)
        logger.info("pyamg: %d iterations, relative residual %.1e",
                    count, relative)
        if not chosen["reused"]:
            kept.setdefault("iterations", count)
        elif count > 2 * kept.get("iterations", count):
            kept.clear()        # it has aged: a new one next time
        return x, relative, count

    def solve_directly(A, reached):
        """The direct back end's ``solve(b)`` for ``A``, on which the
        iterations reached ``reached``; logged."""
        name = direct.choose(A) if hasattr(direct, "choose") \
            else "the direct solver"
        solver.fallbacks += 1
        logger.log(logging.WARNING if own else logging.INFO,
                   "%s did not converge on %d free DOFs (%s; tolerance "
                   "%.0e): solved by %s instead, as are the further systems "
                   "of this pattern in the load step",
                   "pyamg (asked for by name)" if own else "auto: pyamg",
                   A.shape[0], reached, tol, name)
        kept["direct"] = True   # this pattern's next systems: directly
        return direct.factorise(A)

    def factorise(A, modes=None, **kwargs):
        A = A.tocsr()
        same = same_pattern(A, kept) and (
            modes is kept["modes"] or np.array_equal(modes, kept["modes"]))
        if same and kept.get("direct"):
            logger.debug("pyamg: %d free DOFs solved directly (this pattern "
                         "did not converge)", A.shape[0])
            return direct.factorise(A)
        accel = "cg" if is_symmetric(A) else "gmres"
        ml = kept["ml"] if same else hierarchy(A, modes)
        chosen = {"ml": ml, "reused": bool(same), "modes": modes}

        def solve(b):
            if "direct" in chosen:
                return chosen["direct"](b)
            try:
                x, relative, count = iterate(A, chosen, accel, b)
            except SingularSystemError as err:      # pyamg's own failure
                if not fallback:
                    raise
                chosen["direct"] = solve_directly(A, str(err))
                return chosen["direct"](b)
            if relative <= tol:
                return x
            if not fallback:
                raise SingularSystemError(
                    "pyamg did not converge: relative residual {:.1e} after "
                    "{} iterations (the tangent may be singular or too far "
                    "from symmetric positive definite for the iterative "
                    "solver; try solver='scipy' or 'pypardiso')".format(
                        relative, count))
            chosen["direct"] = solve_directly(
                A, "relative residual {:.1e} after {} iterations".format(
                    relative, count))
            return chosen["direct"](b)
        return solve

    def solver(A, b, modes=None, **kwargs):
        return factorise(A, modes=modes)(b)

    def forget():
        """The hierarchy, and what the own direct back end keeps, dropped."""
        kept.clear()
        if own:
            direct.forget()
    solver.factorise = factorise
    solver.forget = forget
    solver.wants_modes = True
    solver.iterations = []
    solver.hierarchies = 0
    solver.fallbacks = 0
    return solver


def factorised(solver: Callable, A, **kwargs) -> Callable:
    """``solve(b)`` for the matrix ``A``: the back end's ``factorise(A)``
    (one factorisation, any number of right-hand sides), or, for a solver
    function without one (a scikit-fem solver of one's own), a call of
    ``solver(A, b)`` per right-hand side."""
    if hasattr(solver, "factorise"):
        return solver.factorise(A, **kwargs)
    return lambda b: solver(A, b, **kwargs)


def available_solvers() -> list:
    """Names of the back ends importable here."""
    names = ["scipy"]
    for name in ("pypardiso", "pyamg"):
        if _installed(name):
            names.append(name)
    return names


def solver_direct_auto(dim: int = 2, log: bool = True) -> Callable:
    """The direct back end of ``"auto"`` for each system, for a grid of
    dimension ``dim``: Pardiso from :data:`AUTO_PARDISO_FROM` free DOFs
    where pypardiso is installed, but for a banded system: below the size
    of :data:`AUTO_SUPERLU_BANDED`, one whose bandwidth after a reverse
    Cuthill-McKee ordering (:func:`rcm_bandwidth`) is at most its
    bandwidth there; SuperLU otherwise.  ``solver.choose(A)`` names the
    back end for ``A``; ``solver.chosen`` lists those taken, in order, each
    logged once (``log``) with the system it was first taken for (and its
    bandwidth where that decided).

    The decision (measured, ``benchmarks/solver_structure.py``, in
    ``benchmarks/README.md``): the size alone took Pardiso for a thin
    column, where SuperLU is faster, because Pardiso's analysis of each
    new pattern (each load step where points cross cells) costs more
    than SuperLU's whole factorisation of a narrow band.  The solve phase
    of 4 finite-deformation steps with SuperLU takes 0.63-0.99 of
    Pardiso's on 2D columns of bandwidth 3-12 (one to three cells wide)
    with 2e3-1.6e4 free DOFs, 1.2-1.6 on bandwidths 16-32 (four and eight
    cells) and 1.5-3.8 on squares (bandwidth above 100); from 3e4 DOFs
    Pardiso's threads make up for the analysis even at bandwidth 3 (0.86-
    1.07 per step of three solves).  In 3D only a column one cell across
    on rollers (bandwidth 7) gains, below 3000 DOFs (0.60-0.82; at 4096
    DOFs 0.63 and 1.13 in two measurements, 1.15-1.46 from 8192).  The
    cells across the grid's narrowest axis would say less (a slanted
    strip, supports on rollers) and are not the solver's to know; the
    bandwidth of the condensed matrix is.  It costs one breadth-first
    pass (0.4 ms at 2e3 DOFs, 5.6 ms at 3.3e4: 3% of Pardiso's time for
    a load step of three solves on a square), computed only in the range
    where it decides and kept for the pattern (a load step's Newton
    iterations share one).

    >>> from scipy.sparse import diags
    >>> solver = solver_direct_auto(2)
    >>> band = diags([-1., 2.5, -1.], [-1, 0, 1], shape=(5000, 5000))
    >>> solver.choose(band.tocsr())           # tridiagonal: banded
    'scipy (SuperLU)'
    """
    if dim not in AUTO_PARDISO_FROM:
        raise InvalidInputError("dim must be 1, 2 or 3, got {!r}".format(dim))
    has_pardiso = "pypardiso" in available_solvers()
    superlu = solver_direct_checked()
    pardiso = {}                # created for the first system it takes

    def measured(A) -> bool:
        """Whether the choice of ``A`` depends on its bandwidth."""
        return has_pardiso and AUTO_PARDISO_FROM[dim] <= A.shape[0] < \
            AUTO_SUPERLU_BANDED.get(dim, (0, 0))[1]

    def choose(A) -> str:
        if not has_pardiso or A.shape[0] < AUTO_PARDISO_FROM[dim]:
            return "scipy (SuperLU)"
        if measured(A) and rcm_bandwidth(A) <= AUTO_SUPERLU_BANDED[dim][0]:
            return "scipy (SuperLU)"
        return "pypardiso"

    def factorise(A, **kwargs):
        name = choose(A)
        if name not in solver.chosen:           # logged once per back end
            solver.chosen.append(name)
            if log:
                logger.info("auto: %s for %d free DOFs%s", name, A.shape[0],
                            " (bandwidth {})".format(rcm_bandwidth(A))
                            if measured(A) else "")
        if name == "scipy (SuperLU)":
            return superlu.factorise(A)
        if not pardiso:
            pardiso["solver"] = solver_pypardiso()
        return pardiso["solver"].factorise(A)

    def solver(A, b, **kwargs):
        return factorise(A)(b)

    def forget():
        """What Pardiso keeps within a load step, dropped."""
        for kept in pardiso.values():
            kept.forget()
    solver.factorise = factorise
    solver.choose = choose
    solver.forget = forget
    solver.chosen = []
    return solver


def solver_auto(dim: int = 2) -> Callable:
    """The back end measured fastest for each system among those
    installed, for a grid of dimension ``dim``, by its size and, between
    the direct ones, its structure: SuperLU below
    :data:`AUTO_PARDISO_FROM` free DOFs, for a banded system (a thin
    column: :data:`AUTO_SUPERLU_BANDED`) or where pypardiso is not
    installed; Pardiso otherwise (:func:`solver_direct_auto`, which says
    why); AMG-CG from :data:`AUTO_AMG_FROM` when pyamg is installed (in 3D
    from 5000 DOFs without Pardiso).  Logs each back end it takes, once,
    with the size of the first system it took it for.  A system the
    iterative solver does not converge on (CG stalled at an
    ill-conditioned tangent's round-off, a tangent far from positive
    definite, a singular one) goes to the direct back end, which solves it
    or refuses it as singular (:func:`solver_pyamg`, one INFO line).

    >>> import numpy as np
    >>> from scipy.sparse import diags
    >>> solver = solver_auto()
    >>> solver(diags([2.] * 3).tocsr(), np.ones(3)).tolist()
    [0.5, 0.5, 0.5]
    >>> solver.chosen
    ['scipy (SuperLU)']
    >>> solver.takes_modes(3)      # solved directly: no rigid-body modes
    False
    """
    direct = solver_direct_auto(dim)
    installed = available_solvers()
    amg_from = AUTO_AMG_FROM["pypardiso" if "pypardiso" in installed
                             else "scipy (SuperLU)"][dim]
    iterative = solver_pyamg(fallback=direct, dim=dim) \
        if "pyamg" in installed else None

    def factorise(A, modes=None, **kwargs):
        if iterative is None or A.shape[0] < amg_from:
            return direct.factorise(A)
        if "pyamg" not in solver.chosen:
            solver.chosen.append("pyamg")
            logger.info("auto: pyamg for %d free DOFs", A.shape[0])
        return iterative.factorise(A, modes=modes)

    def solver(A, b, modes=None, **kwargs):
        return factorise(A, modes=modes)(b)

    def forget():
        """What the back ends keep within a load step, dropped."""
        direct.forget()
        if iterative is not None:
            iterative.forget()

    def takes_modes(nfree: int) -> bool:
        """Whether a system of ``nfree`` DOFs goes to the iterative back
        end, the one that reads the rigid-body modes (the direct ones do
        not: a caller need not form them)."""
        return iterative is not None and nfree >= amg_from
    solver.factorise = factorise
    solver.forget = forget
    solver.wants_modes = iterative is not None
    solver.takes_modes = takes_modes
    solver.chosen = direct.chosen       # one list: the order they came in
    return solver


FACTORIES = {"scipy": solver_direct_checked, "pypardiso": solver_pypardiso,
             "pyamg": solver_pyamg, "auto": solver_auto}

#: what each solver name is (the logs and the README name the back ends)
SOLVER_WORDS = {"scipy": "SciPy's SuperLU", "pypardiso": "MKL's Pardiso",
                "pyamg": "AMG-CG, algebraic multigrid",
                "auto": "one of these by the system's size"}

#: the names of the back ends and their libraries, lower case, by the
#: solver name they mean (trial 111 tried "superlu", "SuperLU", "pardiso")
SOLVER_ALIASES = {"superlu": "scipy", "splu": "scipy", "spsolve": "scipy",
                  "pardiso": "pypardiso", "mkl": "pypardiso",
                  "amg": "pyamg", "amg-cg": "pyamg", "cg": "pyamg"}


def solver_choices() -> str:
    """The solver names with what each is: ``'scipy' (SciPy's SuperLU),
    ...``."""
    return ", ".join("{!r} ({})".format(k, v) for k, v in
                     SOLVER_WORDS.items())


def solver_meant(name) -> str:
    """``"; did you mean 'scipy'?"`` for a solver ``name`` that names a
    back end or its library (``"SuperLU"``, ``"pardiso"``) or is a name
    misspelt, else ``""``.

    >>> solver_meant("SuperLU"), solver_meant("Pardiso")
    ("; did you mean 'scipy'?", "; did you mean 'pypardiso'?")
    """
    from ..spelling import did_you_mean
    if isinstance(name, str) and name.strip().lower() in SOLVER_ALIASES:
        return "; did you mean {!r}?".format(
            SOLVER_ALIASES[name.strip().lower()])
    return did_you_mean(name, FACTORIES)


def check_solver(solver) -> None:
    """Refuse (:class:`~skfem_mpm.errors.InvalidInputError`) a ``solver``
    that is neither ``None``, a function nor one of the names, saying
    which is which and the name meant (``Options`` checks on creation:
    a trial's ``Options(solver="umfpack")`` was refused at the run).

    >>> check_solver("pardiso")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: linear solver must be one of 'scipy' (SciPy's SuperLU), 'pypardiso' (MKL's Pardiso), 'pyamg' (AMG-CG, algebraic multigrid), 'auto' (one of these by the system's size) or a function f(A, b) -> x, got 'pardiso'; did you mean 'pypardiso'?
    """
    if solver is None or callable(solver):
        return
    if not isinstance(solver, str) or solver not in FACTORIES:
        raise InvalidInputError(
            "linear solver must be one of {} or a function f(A, b) -> x, "
            "got {!r}{}".format(solver_choices(), solver,
                                solver_meant(solver)))


def get_solver(solver: Union[None, str, Callable], dim: int = 2) -> Callable:
    """A solver function from a name (``"scipy"``, ``"pypardiso"``,
    ``"pyamg"``, ``"auto"``), a function, or ``None`` (``"auto"``);
    ``dim``, the grid's dimension, sets the sizes at which ``"auto"``
    changes back end (and the direct back end of pyamg's fallback)."""
    if solver is None:
        solver = "auto"
    if callable(solver):
        return solver
    check_solver(solver)
    if solver in ("auto", "pyamg"):     # their direct choice by dimension
        return FACTORIES[solver](dim=dim)
    return FACTORIES[solver]()
