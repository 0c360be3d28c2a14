#!/usr/bin/python3
"""plot_sweep.py: runs kfx.plots.sweep (python/kfx/plots/sweep.py) from this checkout; its
documentation is there. Where the package is installed: python -m kfx.plots.sweep."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import checkout_package  # noqa: E402

sys.exit(checkout_package.run("kfx.plots.sweep", "plot_sweep.py", status=2))
