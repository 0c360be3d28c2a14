"""Runs the tools of the kfx package (kfx.study, kfx.plots) from this checkout's python/kfx for
the thin commands beside this file (scripts/kfx_search, scripts/plot_sweep.py, ...), whether or
not the package is built or installed.

The tools are pure Python and need none of the compiled module that ``kfx/__init__.py`` loads,
so the checkout's python/kfx is registered as the package ``kfx`` without running its
``__init__.py``: ``import kfx.study.search`` then reads this checkout's files, also on a machine
where nothing was built (the GPU machine's scripts/gpu_search) and never an older installed copy.

Shell scripts run a module with: python3 scripts/checkout_package.py MODULE [ARGS...]
"""

import importlib
import importlib.machinery
import importlib.util
import os
import sys

PACKAGE_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python",
                           "kfx")


def use_checkout_package():
    """Makes ``kfx.<module>`` import from this checkout's python/kfx (once per process)."""
    if "kfx" in sys.modules:
        return
    spec = importlib.machinery.ModuleSpec("kfx", None, is_package=True)
    package = importlib.util.module_from_spec(spec)
    package.__path__ = [PACKAGE_DIR]
    sys.modules["kfx"] = package


def run(module_name, tool_name, status=2, argv=None):
    """Runs ``module_name``'s main() on ``argv`` (default: the command line's arguments) under
    ``tool_name`` (its errors read "TOOL_NAME: error: ..."); returns the exit status."""
    use_checkout_package()
    module = importlib.import_module(module_name)
    study = importlib.import_module("kfx.study")
    return study.run_tool(tool_name, module.main, sys.argv[1:] if argv is None else argv, status)


if __name__ == "__main__":
    if len(sys.argv) < 2 or not sys.argv[1].startswith("kfx."):
        print("usage: checkout_package.py kfx.MODULE [ARGS...]", file=sys.stderr)
        sys.exit(2)
    sys.exit(run(sys.argv[1], sys.argv[1], argv=sys.argv[2:]))
