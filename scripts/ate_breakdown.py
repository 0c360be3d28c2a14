#!/usr/bin/env python3
"""ate_breakdown.py: runs kfx.study.ate_breakdown (python/kfx/study/ate_breakdown.py) from this checkout; its
documentation is there. Where the package is installed: python -m kfx.study.ate_breakdown."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import checkout_package  # noqa: E402

sys.exit(checkout_package.run("kfx.study.ate_breakdown", "ate_breakdown.py", status=2))
