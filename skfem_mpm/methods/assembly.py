"""A vectorised fast path for the forms the solvers assemble on a
material-point basis, tested to equal scikit-fem's ``asm`` to round-off.

Element matrices are summed over each element's points in the basis's
padded (element, slot) layout, and scattered into a CSR matrix through the
sparsity pattern of the whole grid, computed once per run (a sort of the
element DOF pairs) and shared by every load step and Newton iteration: each
assembly is then one ``np.bincount``, linear in the number of points.  The
matrix carries explicit zeros on inactive DOFs, which condensing onto the
free DOFs drops.

"""
import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

__all__ = ["ElementPattern", "local_stiffness", "local_force",
           "local_load"]

CHUNK = 512             # elements per block (bounds the temporaries)


class ElementPattern:
    """CSR pattern of all elements' DOFs (nloc, nelems) in an N x N matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm.methods.assembly import ElementPattern
    >>> pattern = ElementPattern(np.array([[0, 1], [1, 2]]), 3)
    >>> local = np.ones((1, 2, 2))
    >>> pattern.matrix([(np.array([1]), local)]).toarray().tolist()
    [[0.0, 0.0, 0.0], [0.0, 1.0, 1.0], [0.0, 1.0, 1.0]]

    """

    def __init__(self, element_dofs: ndarray, N: int):
        self.element_dofs, self.N = element_dofs, N
        self._structure = None

    def structure(self):
        """``(scatter, indices, indptr)``, computed on first use (a run
        that never assembles on the element pattern, GIMP, skips it):
        ``scatter[e]`` the CSR positions of element e's matrix entries."""
        if self._structure is None:
            dofs, N = self.element_dofs, self.N
            nloc, nel = dofs.shape
            incidence = csr_matrix((np.ones(dofs.size), dofs.T.ravel(),
                                    np.arange(0, dofs.size + 1, nloc)),
                                   shape=(nel, N))
            pattern = (incidence.T @ incidence).tocsr()
            pattern.sort_indices()
            index = np.int32 if pattern.nnz < 2 ** 31 else np.int64
            # (row, column) keys of the pattern, ascending
            keys = np.repeat(np.arange(N, dtype=np.int64) * N,
                             np.diff(pattern.indptr)) + pattern.indices
            scatter = np.empty((nel, nloc * nloc), dtype=index)
            for s in range(0, nel, CHUNK):
                d = dofs[:, s:s + CHUNK].T.astype(np.int64)    # (k, nloc)
                scatter[s:s + CHUNK] = np.searchsorted(
                    keys, (d[:, :, None] * N + d[:, None, :]).reshape(
                        len(d), -1))
            self._structure = (scatter, pattern.indices.astype(index),
                               pattern.indptr.astype(index))
        return self._structure

    def matrix(self, blocks) -> csr_matrix:
        """Assemble element matrices given in blocks ``(elements, local)``,
        local (len(elements), nloc, nloc): each block is added in place, so
        only one block of element matrices exists at a time."""
        scatter, indices, indptr = self.structure()
        data = np.zeros(len(indices))
        for elements, local in blocks:
            np.add.at(data, scatter[elements].ravel(), local.ravel())
        return csr_matrix((data, indices, indptr), shape=(self.N, self.N))


def local_stiffness(G: ndarray, A: ndarray, w: ndarray, slots: ndarray):
    """Element matrices ``K_(ia)(jc) = sum_slots w A_abcd G_bi G_dj``, block
    by block of elements.

    ``G`` (dim, nloc, nelems, nslots) holds the shape gradients in the
    padded layout of a material-point basis, ``A`` (dim, dim, dim, dim, n)
    and ``w`` (n,) the tangent and weight of every point, in point order
    (A may be one tensor broadcast to all points), and ``slots`` (nelems,
    nslots) the point in every slot (-1 in padding).
    Yields ``(block, local)``: a slice of the elements and their matrices
    (len, nloc, nloc) in interleaved vector order (node-major); the tangent
    is gathered into the layout one block at a time, so no padded or
    weighted copy of it exists.

    """
    dim, nodes, nel = G.shape[0], G.shape[1], G.shape[2]
    uniform = A.strides[-1] == 0          # one tensor broadcast to all points
    for s in range(0, nel, CHUNK):
        e = slice(s, s + CHUNK)
        we = np.where(slots[e] < 0, 0., np.take(w, slots[e]))
        Ae = (A[..., :1, None] if uniform
              else np.take(A, slots[e], axis=-1)) * we  # (..., chunk, nslots)
        Ge = G[:, :, e]
        # AG_abcj = sum_d A_abcd G_dj, per element and slot
        AG = Ae[:, :, :, 0, None] * Ge[0][None, None, None]
        for d in range(1, dim):
            AG += Ae[:, :, :, d, None] * Ge[d][None, None, None]
        # K_i(ajc) = sum_(b, slot) G_bi AG_abcj: one small matmul an element
        k = Ge.shape[2]
        left = Ge.transpose(2, 1, 0, 3).reshape(k, nodes, -1)
        right = AG.transpose(4, 1, 5, 0, 3, 2).reshape(k, left.shape[2], -1)
        yield e, np.matmul(left, right).reshape(k, nodes * dim, nodes * dim)


def local_force(G: ndarray, P: ndarray) -> ndarray:
    """Element vectors ``f_(ia) = sum_slots P_ab G_bi`` with the weights
    folded into P (dim, dim, nelems, slots); returns (nloc, nelems)."""
    dim, nodes = G.shape[0], G.shape[1]
    f = np.einsum("abem,biem->iae", P, G)
    return f.reshape(nodes * dim, -1)


def local_load(N: ndarray, f: ndarray) -> ndarray:
    """Element vectors ``f_(ia) = sum_slots N_i f_a`` of point forces
    (dim, nelems, slots); returns (nloc, nelems)."""
    out = np.einsum("iem,aem->iae", N, f)
    return out.reshape(-1, N.shape[1])
