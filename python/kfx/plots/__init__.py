"""Figures and pages from `kfx sweep` results (matplotlib, imported only when a figure is drawn;
``import kfx.plots`` itself needs nothing beyond the standard library):

- ``kfx.plots.sweep``: step-sweep figures, before/after tables, the Pareto front and a report
  template filled from the results (docs/sweep.md; scripts/plot_sweep.py).
- ``kfx.plots.presets``: docs/presets.md, each preset's settings, speed, ATE and whether it meets
  its constraint, with a Pareto plot per sequence (scripts/presets_report).
"""

import sys

from ..study import ToolError


def import_pyplot():
    """matplotlib.pyplot on the headless Agg backend; a ToolError saying how to install it when
    matplotlib is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise ToolError(
            f"matplotlib is not installed for {sys.executable}: install python3-matplotlib "
            "(Debian/Ubuntu) or `pip install matplotlib`, or use --no-plots for tables only"
        ) from e
    return plt
