"""Figures whose text can be read: tick labels that do not overlap,
titles clear of other text, and everything inside the figure
(:func:`settle_layout`, which :func:`~skfem_mpm.scenes.plot.save_figure`
applies to every figure, measuring the text without drawing it), and the
check of it (:func:`layout_problems`, which the tests apply to every
figure written, as it is drawn to be saved).

"""
import numpy as np

__all__ = ["settle_layout", "layout_problems", "thin_ticks",
           "raise_titles", "overlapping", "panel_problems"]


def overlapping(boxes) -> bool:
    """Whether any two of the window extents ``boxes`` overlap (by more
    than half a pixel)."""
    if len(boxes) < 2:
        return False
    b = np.array([[x.x0, x.y0, x.x1, x.y1] for x in boxes])
    apart = (np.minimum(b[:, None, 2], b[None, :, 2])
             - np.maximum(b[:, None, 0], b[None, :, 0]) <= .5) | \
        (np.minimum(b[:, None, 3], b[None, :, 3])
         - np.maximum(b[:, None, 1], b[None, :, 1]) <= .5)
    np.fill_diagonal(apart, True)
    return not apart.all()


def tick_boxes(fig, axis, renderer=None) -> list:
    """The window extents of the visible, non-empty tick labels of
    ``axis`` (an x or y axis) as last laid out (by a draw, or
    ``axis.get_tightbbox``), measured with ``renderer`` (default the
    canvas's)."""
    renderer = renderer or fig.canvas.get_renderer()
    lo, hi = sorted(axis.get_view_interval())
    return [t.get_window_extent(renderer)
            for tick in axis.get_major_ticks() for t in (tick.label1,
                                                         tick.label2)
            if t.get_visible() and t.get_text()
            and lo - 1e-9 * (hi - lo) <= tick.get_loc()
            <= hi + 1e-9 * (hi - lo)]


def thin_ticks(fig, renderer) -> bool:
    """Fewer major ticks (:class:`matplotlib.ticker.MaxNLocator`) on
    every axis of ``fig`` whose tick labels overlap (a bar 0.1 m wide
    read "0.0406" for 0.04 and 0.06, a curve's axis in m
    "-0.00200.00175..."), down to 2, then an x axis's labels upright,
    then every other tick while labels come within 2 pixels, down to
    one; whether any changed.  The figure laid out once before (e.g. by
    ``fig.get_tightbbox(renderer)``); each try lays out only its own
    axis (``axis.get_tightbbox``), not the whole figure."""
    from matplotlib.ticker import FixedLocator, MaxNLocator

    def crowded(axis):
        # with a margin of a pixel: labels that touch at the measuring
        # renderer's resolution overlapped once saved at another (a load-
        # displacement curve's "-0.050" and "-0.025" at 120 dpi)
        return overlapping([b.padded(1.) for b in tick_boxes(
            fig, axis, renderer)])
    changed = False
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "linear" or not crowded(axis):
                continue
            changed = True
            for nbins in (4, 3, 2):
                axis.set_major_locator(MaxNLocator(nbins=nbins))
                axis.get_tightbbox(renderer)
                if not crowded(axis):
                    break
            else:
                if axis is ax.xaxis:
                    ax.tick_params(axis="x", labelrotation=90)
                    axis.get_tightbbox(renderer)
                # still touching (a column 0.2 cells wide: "0.8" and "1.6"
                # upright side by side overlapped once saved at another
                # resolution): every other tick, down to one, with a
                # margin of 2 pixels
                while overlapping([b.padded(2.) for b in tick_boxes(
                        fig, axis, renderer)]):
                    lo, hi = sorted(axis.get_view_interval())
                    ticks = [t for t in axis.get_majorticklocs()
                             if lo <= t <= hi]
                    if len(ticks) < 2:
                        break
                    axis.set_major_locator(FixedLocator(ticks[::2]))
                    axis.get_tightbbox(renderer)
    return changed


def raise_titles(fig, renderer) -> bool:
    """Raise each axes' title above the other axes' labels and offsets it
    overlaps (a colour bar's label longer than its bar reached into a 3D
    slice's title); whether any moved.  The figure laid out before, as
    for :func:`thin_ticks`."""
    import matplotlib
    moved = False
    for ax in fig.axes:
        if not ax.get_title():
            continue
        title = ax.title.get_window_extent(renderer)
        others = [t.get_window_extent(renderer) for other in fig.axes
                  if other is not ax for t in (
                      other.xaxis.label, other.yaxis.label,
                      other.xaxis.offsetText, other.yaxis.offsetText)
                  if t.get_visible() and t.get_text()]
        reach = [b.y1 - title.y0 for b in others if overlapping([title, b])]
        if reach:
            points = max(reach) * 72. / fig.dpi + 2.
            ax.set_title(ax.get_title(), pad=matplotlib.rcParams[
                "axes.titlepad"] + points)
            moved = True
    return moved


def settle_layout(fig):
    """Thin overlapping tick labels (:func:`thin_ticks`), raise titles
    over other text (:func:`raise_titles`) and grow ``fig`` until all its
    text lies inside (a wide body's deformed shape lost its title's top
    and its legend's last line, a tall one its title's and legend's
    sides), laid out again (``tight_layout``) where anything changed.

    Measured without drawing: the text is laid out by the figure's tight
    bounding box (the ticks, labels, titles and legends placed, nothing
    rendered), once for a figure that needs no change, and once more
    after each change of its size (at most four).
    """
    renderer = fig.canvas.get_renderer()
    box = fig.get_tightbbox(renderer)                       # inches
    if thin_ticks(fig, renderer) | raise_titles(fig, renderer):
        fig.tight_layout()
        box = fig.get_tightbbox(renderer)
    for _ in range(4):
        width, height = fig.get_size_inches()
        grow = (max(0., -box.x0) + max(0., box.x1 - width),
                max(0., -box.y0) + max(0., box.y1 - height))
        if max(grow) < .01:
            return
        fig.set_size_inches(width + grow[0] + .1 * (grow[0] > 0),
                            height + grow[1] + .1 * (grow[1] > 0))
        fig.tight_layout()
        renderer = fig.canvas.get_renderer()
        box = fig.get_tightbbox(renderer)


def panel_problems(fig, renderer) -> list:
    """Colour bars longer than the axes they belong to (trial 87: beside
    a low slope drawn at equal aspect, twice its height), and pictures
    at equal aspect side by side in a row of subplots with different
    heights (trial 87: ``compare``'s panel with the colour bar was drawn
    smaller than the other, its title lower), by more than 2 pixels and
    2%; as laid out by a draw with ``renderer``."""
    problems, index = [], {ax: k for k, ax in enumerate(fig.axes)}
    for ax in fig.axes:
        for mappable in ax.collections + ax.images:
            bar = getattr(mappable, "colorbar", None)
            if bar is None or bar.ax not in index:
                continue
            along = 3 if bar.orientation == "vertical" else 2
            own, its = (np.array(a.get_window_extent(renderer).bounds)
                        [along] for a in (bar.ax, ax))
            if own > 1.02 * its + 2.:
                problems.append("axes {}: colour bar {:.0f} pixels long "
                                "beside axes {} of {:.0f}".format(
                                    index[bar.ax], own, index[ax], its))
    rows = {}
    for ax in fig.axes:
        spec = ax.get_subplotspec() if hasattr(ax, "get_subplotspec") \
            else None
        if spec is not None and ax.get_aspect() == 1. and \
                ax.get_visible() and ax.axison:
            rows.setdefault((id(spec.get_gridspec()), spec.rowspan.start,
                             spec.rowspan.stop), []).append(ax)
    for row in rows.values():
        boxes = [ax.get_window_extent(renderer) for ax in row]
        heights = [b.height for b in boxes]
        if max(heights) - min(heights) > max(2., .02 * max(heights)):
            problems.append("axes {}: panels of one row {} pixels high"
                            .format(", ".join(str(index[ax]) for ax in row),
                                    " and ".join("{:.0f}".format(h)
                                                 for h in heights)))
    return problems


def layout_problems(fig, renderer=None) -> list:
    """Text of ``fig`` that cannot be read: titles, axis and tick labels,
    colour bars' offsets and legends that leave the figure, tick labels
    of one axis that overlap, titles overlapping other text (a colour
    bar's "1e-5" over a tall bar's title), and colour bars longer than
    their axes and panels of a row of different heights
    (:func:`panel_problems`).  Empty when all is well.

    ``renderer``: that of a draw of ``fig`` just made (a ``draw_event``'s,
    e.g. while the figure is saved: the text as saved, at the saving
    resolution); default: ``fig`` drawn first, without rendering.

    >>> from skfem_mpm.scenes.plot import (layout_problems, pyplot,
    ...                                    settle_layout)
    >>> fig, ax = pyplot().subplots(figsize=(2, 2))
    >>> _ = ax.set_title("a title far too long for a figure 2 inches wide")
    >>> layout_problems(fig)[0]
    'axes 0: title leaves the figure'
    >>> settle_layout(fig)
    >>> layout_problems(fig)
    []
    >>> pyplot().close(fig)
    """
    if renderer is None:
        fig.draw_without_rendering()
        renderer = fig.canvas.get_renderer()
    whole = fig.bbox
    problems = []

    def extent(text):
        return text.get_window_extent(renderer) if text.get_visible() \
            and text.get_text() else None
    titles = []
    for k, ax in enumerate(fig.axes):
        named = [("title", t) for t in (ax.title, ax._left_title,
                                        ax._right_title)]
        named += [("x label", ax.xaxis.label), ("y label", ax.yaxis.label),
                  ("x offset", ax.xaxis.offsetText),
                  ("y offset", ax.yaxis.offsetText)]
        legend = ax.get_legend()
        if legend is not None:
            named += [("legend", t) for t in legend.get_texts()]
            if legend.get_title().get_text():
                named.append(("legend", legend.get_title()))
        for name, text in named:
            box = extent(text)
            if box is None:
                continue
            if name == "title":
                titles.append((k, box))
            if box.x0 < whole.x0 - .5 or box.x1 > whole.x1 + .5 or \
                    box.y0 < whole.y0 - .5 or box.y1 > whole.y1 + .5:
                problems.append("axes {}: {} leaves the figure".format(
                    k, name))
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            boxes = tick_boxes(fig, axis, renderer)
            if overlapping(boxes):
                problems.append("axes {}: {} tick labels overlap".format(
                    k, name))
            if any(b.x0 < whole.x0 - .5 or b.x1 > whole.x1 + .5
                   or b.y0 < whole.y0 - .5 or b.y1 > whole.y1 + .5
                   for b in boxes):
                problems.append("axes {}: {} tick labels leave the figure"
                                .format(k, name))
    problems += panel_problems(fig, renderer)
    others = [(k, extent(t)) for k, ax in enumerate(fig.axes)
              for t in (ax.xaxis.offsetText, ax.yaxis.offsetText,
                        ax.xaxis.label, ax.yaxis.label)]
    for k, title in titles:
        if any(box is not None and overlapping([title, box])
               for j, box in others):
            problems.append("axes {}: title overlaps other text".format(k))
    return problems
