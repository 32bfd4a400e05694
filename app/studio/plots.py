"""What the studio's pyqtgraph plots share: a legend under the plot, never over its curves, and plain axes.

The library dock's spectral plots and the Shade Finder's use :func:`legend_below` (pyqtgraph's own legend
lies inside the plot, over the curves, in a 380 px dock) and :func:`plain_axis` (pyqtgraph rescales an axis
whose values are fractions to milli-units, so 0.2–0.6 read as 200–600). pyqtgraph is imported by the
callers, after the first frame (it costs about a second of start-up).
"""

from __future__ import annotations

from typing import Any


def legend_below(plot: Any, columns: int = 3) -> Any:
    """Give ``plot`` (a ``pg.PlotWidget``) a legend in a row of its own under the bottom axis.

    Curves plotted with a ``name`` are listed there, and :meth:`PlotItem.clear` empties it, as with
    pyqtgraph's own legend. Returns the ``pg.LegendItem``.
    """
    import pyqtgraph as pg

    item = plot.getPlotItem()
    legend = pg.LegendItem(colCount=columns, horSpacing=12, verSpacing=-6, labelTextSize="8pt")
    item.layout.addItem(legend, 4, 1)  # rows: title, top axis, the view and side axes, bottom axis, legend
    item.legend = legend  # where PlotItem.addItem lists named curves (and removeItem unlists them)
    return legend


def plain_axis(plot: Any, side: str, label: str) -> None:
    """Label ``plot``'s ``side`` axis ``label`` and show its values as they are (no SI prefix rescaling)."""
    axis = plot.getPlotItem().getAxis(side)
    axis.enableAutoSIPrefix(False)
    plot.setLabel(side, label)
