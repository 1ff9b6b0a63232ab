"""Run output for ParaView and for scripts: a VTU time series of the points
(all their state as point data) and of the active grid (the step's nodal
displacement increment and the support reactions), from step 0 (the
start) on, PVD collections and ``summary.json`` (checkpoints:
:mod:`skfem_mpm.scenes.checkpoint`).  Every file is written atomically;
the fields and their units are tabled in the README (the units the
scene's numbers are in, :mod:`~skfem_mpm.scenes.units`: SI, or kN and kPa
with ``units = "kN-m"``).

"""
import json
from pathlib import Path
from typing import Optional

import numpy as np
from numpy import ndarray

from .io import atomic_path
from ..quadrature.points import MaterialPoints

__all__ = ["SeriesWriter", "write_summary", "point_cloud", "von_mises",
           "without_negative_zeros", "contact_pressure_fields"]


def _pad3(a: ndarray) -> ndarray:
    """(dim, n) vectors as (n, 3) for VTK."""
    out = np.zeros((a.shape[1], 3))
    out[:, :a.shape[0]] = a.T
    return out


def von_mises(stress: ndarray) -> ndarray:
    """The von Mises equivalent stress ``sqrt(3/2) |dev sigma|`` of
    stresses (3, 3, n)."""
    n = stress.shape[-1]
    return np.sqrt(1.5) * np.linalg.norm(
        (stress - np.einsum("iip->p", stress) / 3
         * np.eye(3)[:, :, None]).reshape(9, n), axis=0)


def point_cloud(points: MaterialPoints):
    """The points as a meshio mesh of vertices with all state fields.

    The vertices lie at the points' current positions ``x`` (padded to
    3D), in the points' order (a point's index is its vertex id), with
    the point data of the README's table of ``points_NNNN.vtu``:
    ``volume``, ``volume0``, ``body``, ``displacement``,
    ``initial_position``, ``force`` (3-vectors), ``stress`` (Cauchy,
    tension positive), ``strain``, ``F`` (the identity in small strain)
    as 9 columns each, row by row, ``von_mises``, ``domain`` (the GIMP
    half-lengths, where the points have domains), ``velocity`` and
    ``acceleration`` (dynamic runs) and every variable of the material's
    ``state`` (``state_<name>`` where it would repeat a name above);
    ``yielding`` is :class:`SeriesWriter`'s, which compares two steps.
    ``.write(path)`` writes any format meshio knows by the suffix:
    ``.vtu`` with meshio alone, ``.xdmf`` needs ``h5py`` too (not a
    dependency of skfem-mpm: ``pip install h5py``).

    Examples
    --------
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> from skfem_mpm.scenes.output import point_cloud
    >>> cloud = point_cloud(seed_points(MeshQuad(), 2))
    >>> cloud.points.shape, cloud.point_data["stress"].shape
    ((4, 3), (4, 9))

    """
    import meshio
    n = points.n
    data = {
        "volume": points.volume, "volume0": points.volume0,
        "body": points.body.astype(np.float64),
        "displacement": _pad3(points.displacement),
        "initial_position": _pad3(points.x0), "force": _pad3(points.force),
        "stress": points.stress.reshape(9, n).T,
        "strain": points.strain.reshape(9, n).T,
        "F": points.F.reshape(9, n).T,
        "von_mises": von_mises(points.stress),
    }
    if points.domain is not None:
        data["domain"] = _pad3(points.domain)
    for name in ("velocity", "acceleration"):     # dynamic runs
        if getattr(points, name) is not None:
            data[name] = _pad3(getattr(points, name))
    for name, value in points.state.items():     # the material's variables
        data[name if name not in data else "state_" + name] = value
    return meshio.Mesh(_pad3(points.x), [("vertex", np.arange(n)[:, None])],
                       point_data=data)


CELL_TYPES = {(1, 2): "line", (2, 4): "quad", (2, 3): "triangle",
              (3, 8): "hexahedron", (3, 4): "tetra"}


def active_grid(mesh, elements: Optional[ndarray], u: Optional[ndarray],
                reactions: Optional[ndarray] = None):
    """The grid's active elements (``None``: every cell) with the step's
    nodal displacement increment ``u`` (``displacement_increment``) and
    the reactions of the supports (``reaction``), vectors over the grid
    DOFs; zero where not given (step 0)."""
    import meshio
    t = mesh.t if elements is None else mesh.t[:, np.asarray(
        elements, dtype=np.int64).ravel()]
    if mesh.t.shape[0] == 8:
        t = t[[0, 2, 4, 1, 3, 6, 7, 5]]       # scikit-fem to VTK hexahedra
    cell = CELL_TYPES[(mesh.dim(), mesh.t.shape[0])]
    nodal = mesh.dim() * mesh.nvertices
    data = {name: np.zeros((mesh.nvertices, 3)) if v is None else _pad3(
        v[:nodal].reshape(-1, mesh.dim()).T)
        for name, v in (("displacement_increment", u),
                        ("reaction", reactions))}
    return meshio.Mesh(_pad3(mesh.p), [(cell, t.T)], point_data=data)


def contact_pressure_fields(record) -> dict:
    """The points' contact pressure and its area per obstacle of a step's
    ``record`` (:attr:`~skfem_mpm.StepRecord.contact_pressure`,
    ``contact_area``) as point fields ``contact<i>_pressure`` and
    ``contact<i>_area`` (zero where a point does not press); ``{}``
    without obstacles."""
    fields = {}
    for name in ("pressure", "area"):
        values = getattr(record, "contact_" + name, None)
        if values is None:
            continue
        for i, row in enumerate(values.toarray()):
            fields["contact{}_{}".format(i, name)] = row
    return fields


#: the state variable whose growth in a step marks plastic flow
PLASTIC_STRAIN = "equivalent_plastic_strain"


def pvd_time(t: float) -> float:
    """A step's time (or load factor) as a collection lists it: to 12
    significant digits, so that the round-off of summed time steps does not
    show (five steps of 0.01 end at 0.049999999999999996, written 0.05); the
    run and its files keep the time as computed.

    >>> pvd_time(0.01 + 0.01 + 0.01 + 0.01 + 0.01), pvd_time(1 / 3)
    (0.05, 0.333333333333)
    """
    return float("{:.12g}".format(t))


class SeriesWriter:
    """Writes ``points_NNNN.vtu`` and ``grid_NNNN.vtu`` per step and keeps
    ``points.pvd`` / ``grid.pvd`` up to date.

    Points of a plastic material (one with an ``equivalent_plastic_strain``)
    also get the yield flag ``yielding``: 1 where the plastic strain grew in
    the step (the point flowed plastically), else 0; ``points`` is the state
    before the first step written (the start, or the checkpoint a run
    resumes from).
    """

    def __init__(self, outdir, mesh, points: Optional[MaterialPoints] = None):
        self.outdir = Path(outdir)
        self.mesh = mesh
        self.entries = []
        self.plastic_strain = None if points is None else \
            points.state.get(PLASTIC_STRAIN)

    def write(self, step: int, time: float, points: MaterialPoints,
              elements: Optional[ndarray], u: Optional[ndarray],
              reactions: Optional[ndarray] = None,
              point_data: Optional[dict] = None):
        """Step ``step`` at ``time`` (load factor, or seconds): the points,
        and the ``elements`` of the grid (a step's record's
        ``elements``; ``None``: every cell) with the step's increment
        ``u`` and ``reactions`` (``None`` at step 0, as in
        ``write(0, 0., points, None, None)``); ``point_data``, more
        fields of the points (name: values (n,)), as
        :func:`contact_pressure_fields` gives them."""
        import meshio
        names = ("points_{:04d}.vtu".format(step),
                 "grid_{:04d}.vtu".format(step))
        cloud = point_cloud(points)
        cloud.point_data.update(point_data or {})
        plastic = points.state.get(PLASTIC_STRAIN)
        if plastic is not None:
            before = self.plastic_strain if self.plastic_strain is not None \
                and self.plastic_strain.shape == plastic.shape else 0.
            cloud.point_data["yielding"] = (plastic > before).astype(
                np.float64)
            self.plastic_strain = plastic.copy()
        for name, m in zip(names, (cloud, active_grid(self.mesh, elements,
                                                      u, reactions))):
            with atomic_path(self.outdir / name) as tmp:
                meshio.write(tmp, m, file_format="vtu")
        self.entries.append((time, names))
        for k, collection in enumerate(("points.pvd", "grid.pvd")):
            lines = ['<?xml version="1.0"?>',
                     '<VTKFile type="Collection" version="0.1">',
                     "<Collection>"]
            lines += ['<DataSet timestep="{!r}" file="{}"/>'.format(
                pvd_time(t), n[k]) for t, n in self.entries]
            lines += ["</Collection>", "</VTKFile>"]
            with atomic_path(self.outdir / collection) as tmp:
                Path(tmp).write_text("\n".join(lines) + "\n")

    def restore(self, steps):
        """Re-register the files of the steps ``(step, time)`` already
        written (resume), the start (step 0) among them: those whose two
        files are there (an invocation with ``--no-series`` wrote none,
        and the collections list no file that is missing)."""
        entries = [(t, ("points_{:04d}.vtu".format(s),
                        "grid_{:04d}.vtu".format(s)))
                   for s, t in [(0, 0.)] + list(steps)]
        self.entries = [(t, names) for t, names in entries if all(
            (self.outdir / name).is_file() for name in names)]


def without_negative_zeros(value):
    """``value`` (numbers in dicts, lists and tuples) with every ``-0.0``
    made ``0.0``: the force on an obstacle never touched is the negated
    zero reaction, which was written ``-0.0`` and printed ``-0 N``.

    >>> from skfem_mpm.scenes.output import without_negative_zeros
    >>> without_negative_zeros({"force": [[-0.0, -2.5]], "steps": 3})
    {'force': [[0.0, -2.5]], 'steps': 3}
    """
    if isinstance(value, float):
        return value + 0.           # -0.0 + 0.0 is 0.0, all else itself
    if isinstance(value, dict):
        return {k: without_negative_zeros(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(without_negative_zeros(v) for v in value)
    return value


def write_summary(path, summary: dict):
    """Write ``summary`` as JSON atomically (no ``-0.0`` in it)."""
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(without_negative_zeros(summary),
                                        indent=2, sort_keys=True))
