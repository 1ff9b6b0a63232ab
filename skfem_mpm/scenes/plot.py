"""Plots of point results (matplotlib, imported lazily, Agg backend).

Every figure explains itself: axes labelled with units (the scene's,
:mod:`~skfem_mpm.scenes.units`: the caller names a stress's or a
force's; lengths and times, in m and s in every system, are labelled
here), a title saying what it shows, geometry at equal
aspect in a figure shaped like the body, signed fields on a colour map
centred on zero, compared panels on one colour scale, and any number of
series in distinct styles (:func:`series_styles`).
:func:`figure_problems` checks a figure for these (the tests run it on
every figure the CLI and the examples write).

"""
from typing import NamedTuple, Tuple

import numpy as np

from .io import atomic_path
from .layout import layout_problems, settle_layout, thin_ticks
from .units import shared_unit

#: the units of lengths and times in every system (a figure's axes)
LENGTH, TIME = shared_unit("length"), shared_unit("time")

__all__ = ["pyplot", "save_figure", "draw_plastic_zone", "draw_points",
           "series_styles", "colour_scale", "body_figure_size",
           "figure_problems", "STRESS_NAMES", "mark_peak", "marker_size",
           "draw_deformed_shape", "SupportMarks", "outline",
           "draw_supports", "material_nodes", "side_colorbar",
           "view_limits", "fit_title", "drawn_points",
           "significant", "layout_problems", "thin_ticks",
           "settle_layout", "slice_plane",
           "box_section", "displacement_scale", "scale_note",
           "obstacle_view", "LoadMarks", "scene_load_marks", "draw_loads"]

#: the stress components' names for labels
STRESS_NAMES = {(i, j): "sigma_" + "xyz"[i] + "xyz"[j]
                for i in range(3) for j in range(3)}
#: the diverging colour map of signed fields, the sequential one of others
SIGNED_MAP, UNSIGNED_MAP = "RdBu_r", "viridis"
MARKERS = "osD^vP*Xh<>p"
LINESTYLES = ("-", "--", "-.", ":")


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path, dpi: int = 120, trim: bool = False):
    """Write ``fig`` to ``path`` (PNG) atomically and close it, laid out
    so that its text can be read (:func:`settle_layout`), drawn once: the
    place-holder a ``tight_layout`` leaves as the figure's layout engine
    is dropped (``savefig`` drew a figure with one a second time, without
    rendering, to run the engine, which does nothing).  ``trim``: the
    empty margins cut off (a tall 3D slice at equal aspect left a third
    of its figure empty above and below it, trial 98)."""
    from matplotlib.layout_engine import PlaceHolderLayoutEngine
    settle_layout(fig)
    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        fig.set_layout_engine(None)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", **(dict(
            bbox_inches="tight", pad_inches=.1) if trim else {}))
    pyplot().close(fig)


def series_styles(n: int) -> list:
    """``n`` distinct ``dict(color=, marker=, linestyle=)`` for plot
    calls: the ten tab10 colours up to ten series, evenly spaced colours
    of a perceptual map beyond, with markers and line styles cycling on
    their own so that no two series look alike.

    >>> from skfem_mpm.scenes.plot import series_styles
    >>> styles = series_styles(25)
    >>> len({(str(s["color"]), s["marker"], s["linestyle"]) for s in styles})
    25
    """
    from matplotlib import colormaps
    colours = colormaps["tab10"].colors[:n] if n <= 10 else \
        [tuple(c) for c in colormaps["turbo"](np.linspace(.05, .95, n))]
    return [dict(color=colours[k], marker=MARKERS[k % len(MARKERS)],
                 linestyle=LINESTYLES[k % len(LINESTYLES)])
            for k in range(n)]


def colour_scale(*fields) -> dict:
    """``dict(cmap=, vmin=, vmax=)`` shared by ``fields``: a diverging map
    centred on zero when their values take both signs, else a sequential
    one over their range; a range within round-off of the values (a
    uniform field) is widened, so that noise is not drawn as a gradient,
    and not across zero (a field of zeros, as a magnitude where nothing
    moved, is drawn from 0 to 1, not from -1 to 1).

    >>> from skfem_mpm.scenes.plot import colour_scale
    >>> colour_scale([-1., 3.]), colour_scale([1., 3.])["cmap"]
    ({'cmap': 'RdBu_r', 'vmin': -3.0, 'vmax': 3.0}, 'viridis')
    >>> scale = colour_scale([1.475e-3, 1.475e-3 + 1e-17])
    >>> scale["vmin"], round(scale["vmax"], 6)
    (0.0, 0.00295)
    >>> colour_scale([0., 0.]), colour_scale([-2., -2.])
    ({'cmap': 'viridis', 'vmin': 0.0, 'vmax': 1.0}, {'cmap': 'viridis', \
'vmin': -4.0, 'vmax': 0.0})
    """
    values = np.concatenate([np.ravel(f) for f in fields])
    lo, hi = float(values.min()), float(values.max())
    if lo < 0 < hi:
        top = max(-lo, hi)
        return dict(cmap=SIGNED_MAP, vmin=-top, vmax=top)
    if hi - lo <= 1e-9 * max(abs(lo), abs(hi)):
        if hi > 0 or lo == 0:
            lo, hi = max(0., lo - abs(lo)), hi + (abs(hi) or 1.)
        else:
            lo, hi = lo - abs(lo), min(0., hi + abs(hi))
    return dict(cmap=UNSIGNED_MAP, vmin=lo, vmax=hi)


def shown_axes(x: np.ndarray, volume: np.ndarray, plane=None):
    """The two coordinate axes a 2D picture of points at ``x`` (dim, n)
    shows, and which points it shows: all in 2D; in 3D the slab one point
    spacing thick across the axis ``plane[0]`` at the layer nearest
    ``plane[1]`` (m; default: through the middle of the body across its
    thinnest axis, the first of equally thin ones), so no layer hides
    another; and the title's note saying where the slice is."""
    if x.shape[0] == 2:
        return (0, 1), np.ones(x.shape[1], dtype=bool), ""
    if plane is None:
        extent = x.max(axis=1) - x.min(axis=1)
        across = int(np.argmin(extent))
        middle = .5 * (x[across].max() + x[across].min())
    else:
        across, middle = int(plane[0]), float(plane[1])
    spacing = np.cbrt(np.median(volume))
    nearest = x[across][np.argmin(np.abs(x[across] - middle))]
    slab = np.abs(x[across] - nearest) < .5 * spacing  # one layer
    shown = tuple(d for d in range(3) if d != across)
    return shown, slab, "slice {} = {:.3g} m".format("xyz"[across],
                                                      x[across][slab].mean())


def slice_plane(x: np.ndarray, boxes=(), motions=(), mirrors=()) -> tuple:
    """``(axis, position)`` of the vertical slice (across x or y; z is up)
    a picture of a 3D body of points at ``x`` (3, n) shows: through the
    boxes ((3, 2) each, m) of what drives the run (obstacles, rigid
    bodies, moving supports) that reach the body (the body's own middle
    without), across the horizontal axis along which they move least
    (``motions``: their displacements), else one with a symmetry plane
    they all lie on, else the body's thinner one, else y (a front view).
    The slice is on that symmetry plane (``mirrors``: ``(axis,
    position)`` of the grid's sides held by rollers across them; a
    quarter model's footing or pile lies on two), else through the
    middle of the boxes' common part.  A horizontal slice through the
    middle of a block missed the punch pressed on its top; one through
    the middle of a quarter model's footing showed none of its soil's
    centre line (trial 98).

    >>> import numpy as np
    >>> from skfem_mpm.scenes.plot import slice_plane
    >>> x = np.mgrid[.05:1:.1, .05:1:.1, .05:.5:.1].reshape(3, -1)
    >>> punch = np.array([[.3, .7], [.3, .5], [.5, .7]])
    >>> wall = np.array([[1., 1.3], [-.1, 1.1], [-.1, .8]])
    >>> slice_plane(x, [punch, wall], [[0, 0, -.03], [-.02, 0, 0]])
    (1, 0.4)
    >>> corner = np.array([[0., .3], [0., .3], [.5, .6]])  # a quarter's
    >>> slice_plane(x, [corner], [[0, 0, -.01]], [(0, 0.), (1, 0.)])
    (1, 0.0)
    """
    lo, hi = x.min(axis=1), x.max(axis=1)
    pad = .1 * float((hi - lo).max())     # the points' centres: the body
    near = [(np.asarray(b, float), np.abs(np.ravel(m)))   # reaches beyond
            for b, m in zip(boxes, motions)
            if (np.asarray(b)[:, 0] <= hi + pad).all()
            and (np.asarray(b)[:, 1] >= lo - pad).all()]
    moving = np.sum([m[:2] for _, m in near], axis=0) if near else \
        np.zeros(2)
    tol = 1e-6 * float((hi - lo).max())

    def mirror(k):
        """The symmetry plane across axis ``k`` every box lies on."""
        return next((float(at) for axis, at in mirrors if axis == k and
                     all(b[k, 0] - tol <= at <= b[k, 1] + tol
                         for b, _ in near)), None) if near else None
    extent = hi[:2] - lo[:2]
    across = min((1, 0), key=lambda k: (moving[k], mirror(k) is None,
                                        extent[k]))
    if not near:
        return across, round(float(.5 * (lo[across] + hi[across])), 12)
    if mirror(across) is not None:
        return across, round(mirror(across), 12)
    # each box's part within the body; their common part if any
    parts = np.array([[max(b[across, 0], lo[across]),
                       min(b[across, 1], hi[across])] for b, _ in near])
    first, last = parts[:, 0].max(), parts[:, 1].min()
    at = .5 * (first + last) if first <= last else parts.mean()
    return across, round(float(at), 12)


def box_section(box: np.ndarray, plane: tuple, axes: tuple):
    """The section of the box ``box`` (3, 2; m) by the plane ``plane``
    (``(axis, position)``) as a polygon (4, 2) in the picture's ``axes``,
    ``None`` where the plane misses it."""
    across, at = plane
    if not box[across, 0] <= at <= box[across, 1]:
        return None
    (x0, x1), (y0, y1) = box[list(axes)]
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def body_figure_size(x: np.ndarray, panels: int = 1, colorbar: bool = True
                     ) -> tuple:
    """A figure size (inches) in which ``panels`` pictures of points at
    ``x`` (2, n) keep their shape: thin bodies get a wide, low figure and
    tall ones a narrow, high one, within 3 to 12 inches."""
    extent = np.ptp(x, axis=1) if x.shape[1] > 1 else np.ones(2)
    aspect = float(np.clip(extent[1] / max(extent[0], 1e-300), .1, 10.))
    panel = 5. / np.sqrt(aspect) if aspect > 1 else 5.
    bar = 1.2 if colorbar else 0.
    width = min(12., panels * max(panel, 2.5) + bar)
    height = float(np.clip((width - bar) / panels * aspect + 1.2, 2.6, 9.))
    return (max(width, 3.), height)


def draw_points(fig, ax, points, values: np.ndarray, label: str, title: str,
                scale: dict = None, colorbar: bool = True, size=None):
    """The points in their current position coloured by ``values`` (n,),
    labelled ``label`` (with its unit); in 1D the values against x.
    ``scale`` (:func:`colour_scale`) defaults to the values' own; the
    colour bar, if drawn, is as high as the axes; without it
    (``colorbar=False``, a panel beside one with it) its room is kept
    empty, so that panels side by side keep one size and their titles one
    height.  Each panel reads alone: its tick labels are shown with its
    axis labels, also on axes that share them (trial 87: the right panel
    of ``compare`` kept "y (m)" without its numbers)."""
    x = points.x
    if x.shape[0] == 1:
        order = np.argsort(x[0])
        ax.plot(x[0, order], values[order], ".-", ms=3, lw=.8)
        ax.set_xlabel("x ({})".format(LENGTH))
        ax.set_ylabel(label)
        ax.set_title(title)
        return None
    (a, b), shown, note = shown_axes(x, points.volume)
    scale = colour_scale(values[shown]) if scale is None else scale
    shown = np.flatnonzero(shown)                # at most DRAWN_MOST
    pick, volume, thinned = drawn_points(x[[a, b]][:, shown], points.volume,
                                         x.shape[0])
    shown = shown[pick]
    note = ", ".join(filter(None, (note, thinned)))
    if size is None:
        size = marker_size(fig, ax, x[[a, b]][:, shown], volume, x.shape[0])
    sc = ax.scatter(x[a, shown], x[b, shown], c=values[shown], s=size,
                    rasterized=True, **scale)
    ax.set_aspect("equal")
    ax.set_xlabel("{} ({})".format("xyz"[a], LENGTH))
    ax.set_ylabel("{} ({})".format("xyz"[b], LENGTH))
    ax.locator_params(nbins=5)
    ax.tick_params(labelleft=True, labelbottom=True)
    fit_title(fig, ax, title + (", " + note if note else ""))
    if colorbar:
        side_colorbar(fig, ax, sc, label)
    else:                    # the bar's room, empty (:func:`side_colorbar`)
        from mpl_toolkits.axes_grid1 import make_axes_locatable
        make_axes_locatable(ax).append_axes("right", size="5%",
                                            pad=.08).set_axis_off()
    return sc


def fit_title(fig, ax, title: str, room: float = .8):
    """Set ``title`` on ``ax``, its lines broken at spaces where one is
    wider than ``room`` times the figure's width (a plastic zone's title
    ran past both edges of a figure shaped like the body)."""
    import textwrap
    text = ax.set_title(title)
    width = text.get_window_extent(fig.canvas.get_renderer()).width
    if width > room * fig.bbox.width:
        lines = title.split("\n")
        chars = max(20, int(max(map(len, lines)) * room * fig.bbox.width
                            / width))
        text.set_text("\n".join(textwrap.fill(line, chars)
                                 for line in lines))
    return text


def side_colorbar(fig, ax, mappable, label: str, size: str = "5%"):
    """A colour bar labelled ``label`` beside ``ax``, as high as it; its
    tick labels carry their own powers of ten (``8e-05``), as a common
    factor ("1e-5") is drawn above the bar, over the title of a tall
    figure."""
    from matplotlib.ticker import FuncFormatter
    from mpl_toolkits.axes_grid1 import make_axes_locatable
    bar = make_axes_locatable(ax).append_axes("right", size=size, pad=.08)
    colorbar = fig.colorbar(mappable, cax=bar, label=label)
    top = max(abs(colorbar.vmin), abs(colorbar.vmax))
    if 0 < top < 1e-3 or top >= 1e5:
        colorbar.formatter = FuncFormatter(lambda v, _: "{:.3g}".format(v))
    return colorbar


def marker_size(fig, ax, x: np.ndarray, volume: np.ndarray,
                dim: int) -> float:
    """A scatter marker size (points^2) for points at ``x`` (2, n) drawn
    at equal aspect in ``ax`` (their box and a margin of a tenth of its
    longer side each way): spaced ``median(volume) ** (1 / dim)``, their
    diameter is about 0.8 of the spacing where that is at least
    :data:`DOT_SPACING` points, within 0.3 to 30; closer, 1.3 of it, so
    that neighbours overlap (trial 87: 96 x 48 points drawn 2.3 points
    apart left white lines a pixel wide between the rows, a moire)."""
    box = ax.get_position()
    extent = np.maximum(np.ptp(x, axis=1), 1e-300)
    shown = extent + .2 * extent.max()
    scale = 72. * min(box.width * fig.get_figwidth() / shown[0],
                      box.height * fig.get_figheight() / shown[1])
    spacing = scale * np.median(volume) ** (1. / dim)        # points
    if spacing < DOT_SPACING:
        return float(max((1.3 * spacing) ** 2, .3))
    return float(np.clip((.8 * spacing) ** 2, .3, 30.))


#: the spacing (points) below which :func:`marker_size`'s markers overlap
DOT_SPACING = 4.


#: the most points one picture draws (:func:`drawn_points`): beyond some
#: 1e5 the markers are finer than the pixels, and each costs the renderer
#: its time (a trial's million points: 66 to 78 s of figures)
DRAWN_MOST = 100_000


def drawn_points(x: np.ndarray, volume: np.ndarray, dim: int,
                 most: int = None) -> tuple:
    """Which of the points at ``x`` (2, n; volumes ``volume``, of
    dimension ``dim``) a picture draws: all, if at most ``most`` (default
    :data:`DRAWN_MOST`); of more, one per square of a regular grid over
    their box, the first by index in each (deterministic, and even over
    the body: no part of it is left out), the squares grown until at
    most ``most`` hold points.  Returns the indices, the volumes for
    :func:`marker_size` (of the squares where they are the wider, so the
    markers still cover the body) and a note for the title ("" when all
    are drawn).

    >>> import numpy as np
    >>> x = np.mgrid[0:1:300j, 0:1:400j].reshape(2, -1)
    >>> shown, volume, note = drawn_points(x, np.full(x.shape[1], 1e-5),
    ...                                    2, most=10_000)
    >>> shown.size <= 10_000, note
    (True, '9801 of 120000 points drawn, one per 0.0102 m square')
    """
    most = DRAWN_MOST if most is None else int(most)
    n = x.shape[1]
    if n <= most:
        return np.arange(n), volume, ""
    lo = x.min(axis=1)
    extent = np.ptp(x, axis=1)
    side = max(np.sqrt(extent[0] * extent[1] / most), extent.max() / most,
               1e-300)
    while True:                       # the squares holding points: <= most
        cells = np.floor((x - lo[:, None]) / side).astype(np.int64)
        key = cells[0] * (int(cells[1].max()) + 1) + cells[1]
        first = np.unique(key, return_index=True)[1]
        if first.size <= most:
            break
        side *= 1.01 * np.sqrt(first.size / most)
    volume = np.full(1, max(float(np.median(volume)), side ** dim))
    return np.sort(first), volume, "{} of {} points drawn, one per {:.3g} " \
        "{} square".format(first.size, n, side, LENGTH)


def figure_problems(fig) -> list:
    """What keeps ``fig`` from explaining itself: axes with data but no x
    or y label or no title (a figure title counts), colour bars without a
    label, signed colour maps not centred on zero.  Empty when all is
    well.

    >>> from skfem_mpm.scenes.plot import figure_problems, pyplot
    >>> fig, ax = pyplot().subplots()
    >>> _ = ax.plot([0, 1], [0, 1])
    >>> figure_problems(fig)
    ['axes 0: no x label', 'axes 0: no y label', 'axes 0: no title']
    >>> pyplot().close(fig)
    """
    problems = []
    suptitle = fig._suptitle is not None and fig._suptitle.get_text()
    bars = {c.colorbar.ax for ax in fig.axes for c in ax.collections
            if getattr(c, "colorbar", None) is not None}
    for k, ax in enumerate(fig.axes):
        if ax in bars:
            if not ax.get_ylabel() and not ax.get_xlabel():
                problems.append("axes {}: colour bar without a label"
                                .format(k))
            continue
        if not (ax.lines or ax.collections or ax.images or ax.patches):
            continue
        for name, text in (("x label", ax.get_xlabel()),
                           ("y label", ax.get_ylabel()),
                           ("title", ax.get_title() or suptitle)):
            if not text:
                problems.append("axes {}: no {}".format(k, name))
        for c in ax.collections:
            cmap = c.get_cmap().name if c.get_array() is not None else ""
            if cmap == SIGNED_MAP and c.norm.vmin != -c.norm.vmax:
                problems.append("axes {}: signed colour map from {} to {}, "
                                "not centred".format(k, c.norm.vmin,
                                                     c.norm.vmax))
    return problems


def draw_plastic_zone(fig, ax, points, title: str, rigid=None,
                      size: float = 2.):
    """Points (2D, coordinates in m) coloured by their equivalent plastic
    strain, its top 2% clipped so the zone shows beside a singular corner;
    the points where ``rigid`` (bool per point) holds in black."""
    plastic = points.state["equivalent_plastic_strain"]
    soil = np.ones(points.n, dtype=bool) if rigid is None else ~rigid
    top = np.percentile(plastic[soil], 98)
    notes = []
    for k, mask in enumerate((soil, rigid)):   # at most DRAWN_MOST each
        if mask is None or not mask.any():
            continue
        mine = np.flatnonzero(mask)
        pick, _, note = drawn_points(points.x[:2, mine], points.volume, 2)
        mine = mine[pick]
        notes.append(note)
        if k == 0:
            sc = ax.scatter(points.x[0, mine], points.x[1, mine],
                            c=plastic[mine], s=size, cmap="viridis",
                            vmax=top, rasterized=True)
        else:
            ax.scatter(points.x[0, mine], points.x[1, mine], c="k",
                       s=size, rasterized=True)
    ax.set_aspect("equal")
    ax.set_xlabel("x ({})".format(LENGTH))
    ax.set_ylabel("y ({})".format(LENGTH))
    notes = ", ".join(filter(None, notes))
    ax.set_title(title + ("\n(" + notes + ")" if notes else ""))
    # beside the axes and as high (trial 87: ``fig.colorbar(ax=ax)`` kept
    # the axes' box, and beside a low slope drawn at equal aspect the
    # bar was twice the plot's height)
    side_colorbar(fig, ax, sc, "equivalent plastic strain (-),\n"
                  "top 2% clipped")


def mark_peak(ax, line, x: np.ndarray, y: np.ndarray, what: str = "",
              peak=None, first: bool = False, assisted: bool = False):
    """The peak of a curve ``line`` marked, its value and the final one in
    the legend, after ``what`` the curve shows where given (trial 87:
    "peak 180.5, final 180.5" beside a footing's force, whose y component
    the terminal said was 179.369, was its magnitude).  The peak is the
    largest ``y``, or the point ``peak`` (an index into ``x`` and ``y``:
    the summary's, :func:`~skfem_mpm.cli.peak_step`); ``first`` gives the
    first point's value too (a curve that does not start at 0);
    ``assisted``: at the peak the material pushes the obstacle along its
    motion (an active wall), the peak being where it pushes least.

    >>> import numpy as np
    >>> from skfem_mpm.scenes.plot import mark_peak, pyplot
    >>> fig, ax = pyplot().subplots()
    >>> line, = ax.plot([0., 1., 2.], [0., 3., 2.])
    >>> mark_peak(ax, line, np.array([0., 1., 2.]),
    ...           np.array([0., 3., 2.]), "magnitude")
    >>> ax.get_lines()[-1].get_label()
    'magnitude: peak 3.000, final 2.000'
    >>> pyplot().close(fig)
    """
    if len(y) > 1:
        peak = int(np.argmax(y)) if peak is None else int(peak)
        ax.plot(x[peak], y[peak], "v" if assisted else "^", ms=7,
                color=line.get_color(), label="{}{} {}{}, final {}".format(
                    what + ": " if what else "",
                    "least push (peak resistance)" if assisted
                    else "peak", significant(y[peak]),
                    ", first {}".format(significant(y[0])) if first
                    else "", significant(y[-1])))


def significant(value: float, digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits, trailing zeros kept, so
    that numbers side by side show the same precision (a legend read
    "peak 7e+04, final 6.555e+04").

    >>> from skfem_mpm.scenes.plot import significant
    >>> significant(7e4), significant(65550.), significant(1000.)
    ('7.000e+04', '6.555e+04', '1000')
    """
    return "{:#.{}g}".format(float(value), digits).rstrip(".").replace(
        ".e", "e")


def draw_footing_curve(ax, movement: np.ndarray, pressure: np.ndarray,
                       label: str, limit: float, limit_label: str,
                       title: str, motion: str = "settlement",
                       strength: str = "c_u"):
    """A footing's pressure over its strength (``strength``: its symbol)
    against its ``motion`` over its width, with the collapse pressure
    ``limit`` of theory as a dashed line, the peak marked, and the peak and
    final values in the legend."""
    line, = ax.plot(movement, pressure, "o-",
                    ms=2 if len(movement) > 50 else 3, label=label)
    mark_peak(ax, line, movement, pressure)
    ax.axhline(limit, color="k", ls="--", label=limit_label)
    ax.set_xlabel("{} / footing width B (-)".format(motion))
    ax.set_ylabel("footing pressure / {} (-)".format(strength))
    ax.set_title(title)
    ax.legend(loc="lower right")


#: the label of :func:`draw_energies`' fall of the balance
DISSIPATION = "numerical dissipation (scheme, mapping, impacts)"


def draw_energies(ax, energies: dict, title: str, unit: str = "J",
                  scale: float = 1.):
    """A dynamic run's kinetic energy, work of the internal forces (the
    points' stresses: stored elastic energy plus plastic work), of the
    external forces (loads) and, where it has any, of the contact forces
    (obstacles, contacts between bodies; friction's work too), and what
    the scheme, the mapping and impacts dissipated (the fall of the
    balance kinetic energy + internal work + contact work - external
    work from its start, the initial kinetic energy: an impact's loss
    within its steps too, as a user trial's block dropped on an incline
    showed) against time; ``energies`` as :meth:`skfem_mpm.Result.
    energies` (without ``contact_work``: none), divided by ``scale``
    (its ``unit``, e.g. ``"kJ/m"`` with 1e3 for a 2D run)."""
    t = np.asarray(energies["time"])
    kinetic, internal, external = (np.asarray(energies[k]) / scale for k in (
        "kinetic", "internal_work", "external_work"))
    contact = np.asarray(energies.get("contact_work", np.zeros_like(
        t))) / scale
    curves = [(kinetic, "-", "kinetic energy"),
              (internal, "--", "internal work (stresses)"),
              (external, ":", "external work (loads)")]
    if np.any(contact):
        curves.append((contact, (0, (5, 1, 1, 1, 1, 1)),
                       "contact work (obstacles, contacts)"))
    for values, style, label in curves:
        ax.plot(t, values, linestyle=style, label=label)
    balance = kinetic + internal + contact - external
    ax.plot(t, balance[0] - balance, "-.", label=DISSIPATION)
    ax.set_xlabel("time ({})".format(TIME))
    ax.set_ylabel("energy ({})".format(unit))
    ax.set_title(title)
    ax.legend(loc="best")


class SupportMarks(NamedTuple):
    """Supported grid nodes as :func:`draw_deformed_shape` marks them:
    ``label`` for the legend, node positions ``nodes`` (dim, m) in m, the
    ``components`` held (axes: 0 x, 1 y, 2 z), ``moving``: a prescribed
    motion rather than a fixed support."""
    label: str
    nodes: np.ndarray
    components: Tuple[int, ...]
    moving: bool = False


class LoadMarks(NamedTuple):
    """Loads as :func:`draw_deformed_shape` draws them: ``label`` for the
    legend, the places ``at`` (dim, k; m) they act on and the
    ``direction`` (dim, k) of each: an arrow onto each place."""
    label: str
    at: np.ndarray
    direction: np.ndarray


def scene_load_marks(scene, points, scale: float = 1.) -> list:
    """A scene's tractions and pressures (at the outermost layer of their
    body's initial points on their side) and point loads (at the points that
    carry them) as :class:`LoadMarks`, at the points drawn (``x0 +
    scale * displacement`` of ``points``), labelled with their values at
    full load in the scene's ``units``."""
    from ..solve.loads import side_axis, side_points
    from .units import unit
    x = points.x0 + scale * points.displacement
    names = [b.name for b in scene.bodies]
    marks = []
    tractions = scene.tractions if points.domain is not None else ()
    initial = points.copy() if tractions else None
    if initial is not None:      # the layer the load was put on
        initial.x = points.x0.copy()
    for t in tractions:
        layer = side_points(initial, t.side,
                            points.body == names.index(t.body))
        if t.traction is None:
            axis, sign = side_axis(t.side, points.dim)
            direction = np.zeros(points.dim)
            direction[axis] = -sign * float(t.pressure)
            what = "pressure {:g}".format(float(t.pressure))
        else:
            direction = np.asarray(t.traction, float)
            what = "traction ({})".format(", ".join(
                "{:g}".format(v) for v in direction))
        marks.append(LoadMarks("{} {} on {} ({})".format(
            what, unit("stress", scene.units), t.body, t.side),
            x[:, layer], np.repeat(direction[:, None], layer.size, axis=1)))
    force = getattr(points, "force", None)
    loaded = np.flatnonzero(np.any(force != 0., axis=0)) \
        if force is not None and scene.point_loads else np.zeros(0, int)
    if loaded.size:
        total = force[:, loaded].sum(axis=1)
        marks.append(LoadMarks("point loads, {} in all ({})".format(
            "({})".format(", ".join("{:.4g}".format(v) for v in total)),
            unit("force", scene.units, points.dim)), x[:, loaded],
            force[:, loaded]))
    return marks


def draw_loads(ax, loads, axes: tuple, length: float, handles: list,
               most: int = 12) -> np.ndarray:
    """Arrows of ``length`` (m) pushing onto the places of the ``loads``
    (:class:`LoadMarks`; 2D), at most ``most`` of each, evenly chosen
    (:func:`evenly`), one legend handle each appended to ``handles``;
    returns the arrows' tails (2, k) for the view."""
    from matplotlib.lines import Line2D
    a, b = axes
    tails = [np.empty((2, 0))]
    for load in loads:
        at = np.asarray(load.at, float)[[a, b]]
        direction = np.asarray(load.direction, float)[[a, b]]
        size = np.linalg.norm(direction, axis=0)
        keep = np.flatnonzero(size > 0.)
        if not keep.size:
            continue
        chosen = keep[evenly(at[:, keep], most)]
        unit = direction[:, chosen] / size[chosen]
        tail = at[:, chosen] - length * unit
        ax.quiver(tail[0], tail[1], length * unit[0], length * unit[1],
                  angles="xy", scale_units="xy", scale=1., color="C3",
                  width=.004, zorder=5)
        tails.append(tail)
        handles.append(Line2D([], [], ls="", marker=r"$\rightarrow$",
                              ms=10, color="C3", label=load.label))
    return np.hstack(tails)


def evenly(at: np.ndarray, most: int) -> np.ndarray:
    """The indices of at most ``most`` of the places ``at`` (dim, n),
    evenly spaced along the line they lie on: sorted along the axis of
    their largest extent (then the others), every ``ceil(n / most)``-th,
    the spare ones split between the ends.  The places of a side's
    layer, every 0.125 m, took 12 of 20 by rounding 12 evenly spaced
    fractional indices, which drew arrows in close pairs; sorted by x
    first, the points of a left side pushed by a pressure came in the
    order of their displacement.

    >>> import numpy as np
    >>> y = np.arange(20) * .125 + .0625
    >>> at = np.vstack([.0625 + 1e-3 * np.sin(7 * y), y])
    >>> np.diff(np.sort(at[1, evenly(at, 12)])).round(6).tolist()
    [0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25]
    """
    at = np.asarray(at, float)
    n = at.shape[1]
    if n <= most:
        return np.arange(n)
    axes = np.argsort(-np.ptp(at, axis=1), kind="stable")
    order = np.lexsort(at[axes[::-1]])
    stride = -(-n // most)
    count = -(-n // stride)
    first = (n - 1 - stride * (count - 1)) // 2
    return order[first::stride][:count]


#: a support's marker by the components it holds: rollers point along
#: the held axis, a square holds every component
SUPPORT_MARKERS = {(0,): ">", (1,): "^", (2,): "d", (0, 2): "p",
                   (1, 2): "h"}


def outline(ax, centres: np.ndarray, half: np.ndarray, pixels: int = 400,
            **style):
    """Draw the outline of the union of the boxes ``centres +- half`` ((2,
    n) each, m) as contour lines (``style``: of
    :meth:`matplotlib.axes.Axes.contour`): the boxes are painted on a
    raster of ``pixels`` along the longer side, so the outline of any
    body, holes and graded point sizes included, is drawn to a pixel."""
    lo = (centres - half).min(axis=1)
    hi = (centres + half).max(axis=1)
    pixel = float((hi - lo).max()) / pixels
    origin = lo - 2 * pixel
    shape = np.ceil((hi - origin) / pixel).astype(int) + 2
    # a box's edges to the nearest pixel edge, rounded first to 1e-6 of a
    # pixel: the shared edge of two touching boxes lies a round-off apart
    # as either's, and on a pixel's middle one ceil split them by a pixel
    # (a user trial's block on x = [-0.6, 0.6, 48]: dashed lines inside)
    first, last = (np.ceil(np.round((centres + sign * half
                                     - origin[:, None]) / pixel - .5, 6))
                   for sign in (-1., 1.))
    first, last = (np.clip(v, 0, shape[:, None]).astype(int)
                   for v in (first, last))
    count = np.zeros(shape + 1)           # 2D difference array of boxes
    for i, j, sign in ((first[0], first[1], 1), (last[0], first[1], -1),
                       (first[0], last[1], -1), (last[0], last[1], 1)):
        np.add.at(count, (i, j), sign)
    inside = count.cumsum(axis=0).cumsum(axis=1)[:-1, :-1] > .5
    cx, cy = (origin[k] + (np.arange(shape[k]) + .5) * pixel
              for k in range(2))
    return ax.contour(cx, cy, inside.T.astype(float), levels=[.5], **style)


def view_limits(x: np.ndarray, margin: float = .1):
    """The lower and upper corners ((2,) each, m) of a picture of the
    places ``x`` (2, n): their box widened on every side by ``margin``
    times its longer side (a point alone: by 1 m).

    >>> import numpy as np
    >>> from skfem_mpm.scenes.plot import view_limits
    >>> lo, hi = view_limits(np.array([[0., .5], [0., 1.]]))
    >>> lo.tolist(), hi.tolist()
    ([-0.1, -0.1], [0.6, 1.1])
    """
    lo, hi = x.min(axis=1), x.max(axis=1)
    pad = margin * (float((hi - lo).max()) or 10.)
    return lo - pad, hi + pad


#: a largest displacement below this share of the body's longer side is
#: drawn exaggerated (:func:`displacement_scale`), to about
#: :data:`EXAGGERATED_SHARE` of it
VISIBLE_SHARE, EXAGGERATED_SHARE = .01, .05


def displacement_scale(x0: np.ndarray, displacement: np.ndarray,
                       half=None) -> float:
    """The factor a deformed shape multiplies the ``displacement`` (dim,
    n) of points at ``x0`` by: 1 (true scale) where the largest is at
    least :data:`VISIBLE_SHARE` of the body's longer side, else the
    largest of 1, 2, 5 times a power of ten that draws it at most
    :data:`EXAGGERATED_SHARE` of that side (trial 87: a slope's 1 cm on
    a section 16 m wide was invisible at true scale).  The side: the
    points' reach, their domains' half-widths ``half`` ((dim, n) or (n,))
    either side of them (trial 103: a 1 m cube seeded 2 per cell on 4
    cells measured by its points' centres, 0.875 m, drew 0.94% of its
    side at true scale and 0.47% x 5); without them, their centres'.

    >>> import numpy as np
    >>> from skfem_mpm.scenes.plot import displacement_scale
    >>> x0 = np.array([[0., 16.], [0., 6.]])
    >>> displacement_scale(x0, np.array([[0., 0.], [0., -.0107]]))
    50.0
    >>> displacement_scale(x0, np.array([[0., .2], [0., 0.]]))
    1.0
    >>> u = np.array([[0., .16], [0., 0.]])
    >>> displacement_scale(x0, u), displacement_scale(x0, u, half=.5)
    (1.0, 5.0)
    """
    reach = np.zeros(1) if half is None else np.asarray(half, float)
    size = float((np.max(x0 + reach, axis=1) - np.min(x0 - reach, axis=1))
                 .max()) if x0.shape[1] > 0 else 0.
    largest = float(np.sqrt((displacement ** 2).sum(axis=0)).max(
        initial=0.))
    if not largest > 0. or not size > 0. or \
            largest >= VISIBLE_SHARE * size:
        return 1.
    wanted = EXAGGERATED_SHARE * size / largest
    power = 10. ** np.floor(np.log10(wanted))
    return float(max(m for m in (1., 2., 5., 10.) if m * power <= wanted
                     * (1 + 1e-12)) * power)


def scale_note(scale: float) -> str:
    """How a deformed shape drawn at ``scale`` (:func:`displacement_scale`)
    is drawn, for its title: ``"true scale"`` or ``"displacements x
    50"``."""
    return "true scale" if scale == 1. else \
        "displacements x {:g}".format(scale)


#: an obstacle reaching out of a deformed shape's view by at most this
#: share of the view's longer side widens it (:func:`draw_deformed_shape`)
OBSTACLE_REACH = .25


def draw_deformed_shape(fig, ax, points, title: str, supports=(),
                        rigid=None, obstacles=(), half=None,
                        coloured: bool = True, plane=None,
                        cell: float = None, scale: float = 1.,
                        loads=()):
    """The deformed shape: the points at ``x0 + displacement`` coloured
    by their displacement magnitude (m; a labelled colour bar) or plain
    (``coloured=False``), the undeformed body as a faint outline, the
    ``supports`` marked at their grid nodes, the points of rigid bodies in
    black with their outline, and obstacles as hatched polygons, each
    labelled in a legend below the axes.  The view (2D, 3D) is the
    material, deformed and undeformed, and the supports drawn, with a
    margin of a tenth of its size (:func:`view_limits`), widened to hold
    the obstacles that reach out of it by at most
    :data:`OBSTACLE_REACH` of its size (trial 87: a footing's box was cut
    at the top); larger ones are cut at its edge (a floor 3 m wide under
    a block of 0.5 m made the block a tenth of the picture), and the
    undeformed outline is drawn over the points (their markers hid it).
    The displacements are drawn times ``scale`` (:func:`displacement_scale`
    chooses it; the title says it, :func:`scale_note`).

    Parameters
    ----------
    fig, ax
        The figure and the axes to draw in; ``title`` is the axes' title.
    points
        :class:`~skfem_mpm.MaterialPoints` of the final state (2D; in 3D
        the slab one point thick at ``plane`` (:func:`shown_axes`; default
        through the middle of the body), its supports on the nearest grid
        plane; in 1D the bar before and after, one above the other).
    supports
        :class:`SupportMarks`: one legend entry each, the marker saying
        which components are held (``>`` x, ``^`` y, ``d`` z, a square:
        all).
    rigid
        ``{name: mask}``: the points (bool per point) of each rigid body.
    obstacles
        ``[(name, polygon)]``: rigid obstacles' outlines, polygons (k, 2)
        in the picture's two coordinates (x, y in 2D; in 3D their sections
        by the slice, :func:`box_section`), m, where they are drawn (moved
        ``scale`` times their motion); ``None``: named as not in the
        slice.
    half
        The points' initial half-widths (dim, n) for the undeformed
        outline; default their domains, else ``volume0 ** (1/dim) / 2``.
    loads
        :class:`LoadMarks` (2D): arrows onto the places they act on
        (:func:`draw_loads`), named in the legend.
    cell
        The grid's cell width: the supports marked only at the nodes
        that carry material, a deformed point closer than ``cell`` along
        every axis (:func:`material_nodes`; a trial's rollers were drawn
        up the grid's whole side, above the soil); ``None``: at every
        node they hold.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import MaterialPoints
    >>> from skfem_mpm.scenes.plot import (SupportMarks, draw_deformed_shape,
    ...                                    pyplot)
    >>> x = np.mgrid[.25:2:.5, .25:1:.5].reshape(2, -1)
    >>> pts = MaterialPoints(x=x, volume=np.full(x.shape[1], .25))
    >>> pts.displacement[1] = -.1 * x[0]
    >>> fig, ax = pyplot().subplots()
    >>> _ = draw_deformed_shape(fig, ax, pts, "a bent block", supports=[
    ...     SupportMarks("left: x, y fixed", np.array([[0., 0.], [0., 1.]]),
    ...                  (0, 1))], obstacles=[("wall", np.array(
    ...         [[2.2, -.5], [2.5, -.5], [2.5, 1.], [2.2, 1.]]))])
    >>> [t.get_text() for t in ax.get_legend().get_texts()][2:]
    ['wall', 'left: x, y fixed']
    >>> pyplot().close(fig)
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon
    dim = points.dim
    x0 = points.x0
    x = x0 + scale * points.displacement      # FE points stay at x0
    if half is None:
        half = points.domain if points.domain is not None else np.tile(
            .5 * points.volume0 ** (1. / dim), (dim, 1))
    rigid = dict(rigid or {})
    soil = ~np.any([m for m in rigid.values()], axis=0) if rigid else \
        np.ones(points.n, dtype=bool)
    magnitude = np.sqrt((points.displacement ** 2).sum(axis=0))
    if dim == 1:             # the bar before (y = 1) and after (y = 0)
        x, x0, half = (np.vstack([v, np.full_like(v, level)]) for v, level
                       in ((x, 0.), (x0, 1.), (half, .15)))
        (a, b), shown, note = (0, 1), np.ones(points.n, dtype=bool), ""
    else:
        (a, b), shown, note = shown_axes(x, points.volume, plane)
    grey, handles = "0.55", []
    outline(ax, x0[[a, b]][:, shown], half[[a, b]][:, shown],
            colors=grey, linewidths=1., linestyles="--", zorder=3.5)
    handles.append(Line2D([], [], color=grey, ls="--",
                          label="undeformed body (outline)"))
    body = shown & soil
    coloured = coloured and body.any()  # a slice of rigid points: plain
    scale = colour_scale(magnitude[body]) if coloured else None
    body, volume, drawn = np.flatnonzero(body), points.volume, []
    if dim > 1:                                   # at most DRAWN_MOST
        pick, volume, thinned = drawn_points(x[[a, b]][:, body],
                                             points.volume, dim)
        body = body[pick]
        drawn.append(thinned)
    size = marker_size(fig, ax, x[[a, b]][:, shown], volume,
                       dim) if dim > 1 else 6.
    sc = ax.scatter(x[a, body], x[b, body], s=size, zorder=2,
                    rasterized=True,
                    **(dict(c=magnitude[body], **scale) if coloured
                       else dict(color="tab:blue")))
    handles.append(Line2D([], [], marker="o", ls="", color="tab:blue" if
                          not coloured else "0.3", label="material points, "
                          "deformed" + (" (colour: |u|)" if coloured
                                        else "")))
    for name, mask in rigid.items():
        mine = mask & shown
        if not mine.any():
            continue
        shape = np.flatnonzero(mine)              # at most DRAWN_MOST
        pick, _, thinned = drawn_points(x[[a, b]][:, shape], points.volume,
                                        max(dim, 2))
        drawn.append(thinned)
        ax.scatter(x[a, shape[pick]], x[b, shape[pick]], s=size, color="k",
                   zorder=3, rasterized=True)
        outline(ax, x[[a, b]][:, mine], half[[a, b]][:, mine], colors="k",
                linewidths=1.2)
        handles.append(Line2D([], [], marker="o", ls="-", color="k",
                              label="rigid body: {}".format(name)))
    marks = []
    if cell is not None:
        supports = [material_nodes(s, points.x0 + points.displacement, cell)
                    for s in supports]
    marked = draw_supports(ax, supports, (a, b), x[:, shown] if dim > 1
                           else None, marks, dim,
                           np.median(points.volume) ** (1. / dim))
    if dim == 2 and loads:
        extent = np.ptp(np.hstack([x0, x]), axis=1).max()
        marked = np.hstack([marked, draw_loads(ax, loads, (a, b),
                                               .08 * extent, marks)])
    if dim > 1:          # the material and the supports, not the obstacles
        h = half[[a, b]][:, shown]
        lo, hi = view_limits(np.hstack([
            c[[a, b]][:, shown] + sign * h for c in (x0, x)
            for sign in (-1., 1.)] + [marked]))
        lo, hi = obstacle_view(lo, hi, [p for _, p in obstacles
                                        if p is not None])
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    for name, polygon in obstacles:
        if polygon is not None:
            ax.add_patch(Polygon(np.asarray(polygon, float), closed=True,
                                 facecolor="0.85", edgecolor="0.2",
                                 hatch="//", lw=1., zorder=1))
        handles.append(Patch(facecolor="0.85", edgecolor="0.2", hatch="//",
                             label=name if polygon is not None else
                             name + " (not in this slice)"))
    handles += marks
    ax.set_aspect("equal")
    ax.set_xlabel("{} ({})".format("xyz"[a], LENGTH))
    if dim == 1:
        ax.set_yticks([0., 1.], ["deformed", "undeformed"])
        ax.set_ylim(-.6, 1.6)
        ax.set_aspect("auto")
        ax.set_ylabel("configuration of the 1D bar")
    else:
        ax.set_ylabel("{} ({})".format("xyz"[b], LENGTH))
        ax.locator_params(nbins=5)
    note = ", ".join(filter(None, [note] + drawn))
    fit_title(fig, ax, title + (", " + note if note else ""))
    if coloured:
        side_colorbar(fig, ax, sc, "displacement magnitude |u| ({})"
                      .format(LENGTH), "4%")
    # what a support's marks are (a lecturer's trial read a root's
    # roller below a bent beam as holding nothing: the node's cell does)
    where = "supports marked at the grid nodes of cells with material" \
        if supports and cell is not None and dim > 1 else None
    legend = ax.legend(handles=handles, loc="upper center", fontsize=8,
                       bbox_to_anchor=(.5, -.2), ncol=2, frameon=False,
                       title=where, title_fontsize=8)
    if legend.get_window_extent(fig.canvas.get_renderer()).width > \
            .95 * fig.bbox.width:      # a tall, thin body's narrow figure
        ax.legend(handles=handles, loc="upper center", fontsize=8,
                  bbox_to_anchor=(.5, -.2), ncol=1, frameon=False,
                  title=where, title_fontsize=8)
    return sc


def obstacle_view(lo: np.ndarray, hi: np.ndarray, polygons) -> tuple:
    """The view ``lo``, ``hi`` ((2,) each, m) widened on each side to
    hold the ``polygons`` ((k, 2) each, m) that overlap it and reach out
    of it there by at most :data:`OBSTACLE_REACH` of its longer side,
    with a margin of a fiftieth of it.

    >>> import numpy as np
    >>> from skfem_mpm.scenes.plot import obstacle_view
    >>> box = np.array([[-.5, 1.45], [.5, 1.45], [.5, 1.95], [-.5, 1.95]])
    >>> lo, hi = obstacle_view(np.array([-.3, -.3]), np.array([3.3, 1.8]),
    ...                        [box])
    >>> [round(float(v), 4) for v in lo], [round(float(v), 4) for v in hi]
    ([-0.572, -0.3], [3.3, 2.022])
    """
    lo, hi = np.array(lo, float), np.array(hi, float)
    size = float((hi - lo).max())
    reach, margin = OBSTACLE_REACH * size, .02 * size
    for polygon in polygons:
        p = np.asarray(polygon, float)
        first, last = p.min(axis=0), p.max(axis=0)
        if np.any(first > hi) or np.any(last < lo):
            continue                               # outside the view
        for d in range(2):
            if hi[d] < last[d] <= hi[d] + reach:
                hi[d] = last[d] + margin
            if lo[d] - reach <= first[d] < lo[d]:
                lo[d] = first[d] - margin
    return lo, hi


def material_nodes(support: SupportMarks, x: np.ndarray, cell: float
                   ) -> SupportMarks:
    """``support`` at those of its nodes that carry material: a point of
    ``x`` (dim, n) closer than ``cell`` along every axis (in a cell the
    node belongs to); none: its label says so.

    >>> import numpy as np
    >>> side = SupportMarks("left", np.array([[0., 0., 0.], [0., 1., 2.]]),
    ...                     (0,))
    >>> material_nodes(side, np.array([[.25], [.75]]), 1.).nodes.tolist()
    [[0.0, 0.0], [0.0, 1.0]]
    """
    from scipy.spatial import cKDTree
    nodes = np.asarray(support.nodes, float)
    if not nodes.size or not x.size:
        return support
    distance = cKDTree(x.T).query(nodes.T, p=np.inf)[0]
    near = distance < cell * (1 - 1e-9)
    label = support.label if near.any() else \
        support.label + " (no node by the material)"
    return support._replace(label=label, nodes=nodes[:, near])


def draw_supports(ax, supports, axes: tuple, slab, handles: list,
                  dim: int, spacing: float = None):
    """The ``supports`` (:class:`SupportMarks`) at their nodes on the
    picture's ``axes``, each in its own colour with a marker by the
    components it holds, and its legend handle appended to ``handles``;
    in 3D only the nodes on the grid plane nearest the slab of points
    ``slab`` (3, n) drawn, where it lies within the points' ``spacing``
    (default: the slab's, from its area and count) of its middle (a
    support elsewhere is named as not in the slice: a base at z = 0 was
    drawn in a slice at z = 0.25; a face the slice crosses is drawn,
    where the spacing of deformed points, a round-off apart, named the
    faces of a block as not in every slice); in 1D the nodes are marked
    on both bars.  Returns the places marked, (2, k)."""
    from matplotlib.lines import Line2D
    a, b = axes
    plane = None
    if dim == 3 and supports:
        across = 3 - a - b
        middle = .5 * (slab[across].min() + slab[across].max())
        levels = np.unique(np.concatenate([s.nodes[across]
                                           for s in supports]))
        plane = levels[np.argmin(np.abs(levels - middle))]
        if spacing is None:
            spacing = np.sqrt(np.ptp(slab[a]) * np.ptp(slab[b])
                              / max(slab.shape[1], 1))
        if abs(plane - middle) > spacing:
            plane = np.nan                   # no support in the slice
    styles = series_styles(len(supports))
    marked = [np.empty((2, 0))]
    for support, style in zip(supports, styles):
        nodes = np.asarray(support.nodes, float)
        held = tuple(sorted(c for c in support.components if c < dim))
        marker = "s" if len(held) == dim else SUPPORT_MARKERS.get(held, "s")
        colour = "tab:red" if support.moving else style["color"]
        label = support.label
        if dim == 1:
            nodes = np.vstack([np.repeat(nodes[0], 2),
                               np.tile([0., 1.], nodes.shape[1])])
        elif dim == 3:
            on = np.isclose(nodes[3 - a - b], plane)
            if not on.any():
                label += " (not in this slice)"
            elif held == (3 - a - b,):
                # a roller on the slice's own plane (a quarter model's
                # symmetry plane): its marks would cover the picture
                label += " (holds the plane of this slice, not marked)"
                on[:] = False
            nodes = nodes[:, on]
        ax.plot(nodes[a], nodes[b], ls="", marker=marker, ms=5, color=colour,
                markeredgecolor="k", markeredgewidth=.4, zorder=4)
        marked.append(nodes[[a, b]])
        handles.append(Line2D([], [], ls="", marker=marker, ms=5,
                              color=colour, markeredgecolor="k",
                              markeredgewidth=.4, label=label))
    return np.hstack(marked)
