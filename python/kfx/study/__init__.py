"""The tools above the library: sweep results and their tables, the Optuna search over settings,
the thesis study's readings, the ATE breakdown and the soak benchmark. They drive the ``kfx``
command line (``kfx sweep``, ``kfx run``) and read what it writes; none needs the compiled
module, and all are pure standard library except the search (Optuna, imported when it runs).

Modules, each also a command (``python -m kfx.study.search ...``; scripts/ has the same names
as before: scripts/kfx_search, scripts/ate_breakdown.py, scripts/soak; scripts/energy_bench
runs kfx.study.energy):

- ``kfx.study.results``: `kfx sweep` results loaded, the measures of a run (ATE, stage times).
- ``kfx.study.tables``: Markdown tables and report templates from those results.
- ``kfx.study.search``: the search mode of `kfx sweep` (docs/sweep.md, "Search").
- ``kfx.study.search_summary``: a search folder's outcome in a few lines (scripts/gpu_search).
- ``kfx.study.thesis``: the readings of docs/thesis-study.md, computed from the results.
- ``kfx.study.ate_breakdown``: what an ATE is made of, per frame and per segment.
- ``kfx.study.soak``: one long run, watching memory and per-frame time.
- ``kfx.study.energy``: scripts/energy_bench's table from `kfx bench --json` results.

The figures are in ``kfx.plots`` (matplotlib).
"""

import os
import sys


class ToolError(Exception):
    """A problem with a tool's input (a results file, a plan, an option), said in one line; a
    tool's command line prints it after its name and exits non-zero."""


def run_tool(name, main, argv=None, status=2):
    """Runs a tool's ``main(argv)``; a ToolError becomes "NAME: error: MESSAGE" on stderr and
    exit status ``status``. Returns the exit status."""
    try:
        return main(argv) or 0
    except ToolError as e:
        print(f"{name}: error: {e}", file=sys.stderr)
        return status


def checkout_root():
    """The kfx checkout this package's source lives in (python/kfx/ of it), or None when the
    package is installed elsewhere."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return root if os.path.exists(os.path.join(root, "scripts", "build")) else None


def default_path(*parts):
    """A path inside the checkout (e.g. build/release/kfx), or relative to the current folder
    when the package is installed outside one."""
    return os.path.join(checkout_root() or os.getcwd(), *parts)
