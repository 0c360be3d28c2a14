#!/usr/bin/env python3
"""End-to-end test of scripts/presets_report on the CPU: a tiny `kfx sweep` (two 16-frame
synthetic sequences at 128x96 in a 64^3 volume; exact and two marked presets, one of which
breaks tracking, and an unmarked run), then the report. It checks the page's settings table
(computed from the runs' configurations), the per-sequence table, the constraint verdicts (the
broken preset must be reported as failing, with its reason), the Pareto PNGs (when matplotlib is
importable) and that a results set without the baseline is a clear error.

Usage: test_presets_report.py KFX_BINARY SOURCE_DIR
Exit status: 0 pass, 1 failure.
"""

import json
import os
import subprocess
import sys
import tempfile

FAILURES = []


def expect(condition, message):
    if not condition:
        FAILURES.append(message)
        print("FAIL:", message)


SEQUENCES = [{"name": name, "input": f"synthetic:frames=16,width=128,height=96,seed={seed}",
              "settings": {"integration_rate": 1, "compute_size_ratio": 1,
                           "volume_resolution": 64}}
             for name, seed in (("room_a", 3), ("room_b", 5))]
PLAN = {
    "name": "presets_report_test", "baseline": "exact", "repeat": 1, "warmup_frames": 0,
    "sequences": SEQUENCES,
    "runs": [
        {"name": "exact", "mark": True},
        {"name": "fast", "preset": "exact", "mark": True,
         "settings": {"pyramid_iterations": "1", "icp_stride_px": 16}},
        {"name": "quality", "preset": "exact", "mark": True,
         "settings": {"icp_robust": "huber", "icp_robust_scale_m": 0.01}},
        {"name": "unmarked", "settings": {"raycast_rate": 2}},
    ],
}


def main():
    kfx, source = sys.argv[1], sys.argv[2]
    script = os.path.join(source, "scripts", "presets_report")
    with tempfile.TemporaryDirectory() as tmp:
        plan = os.path.join(tmp, "plan.json")
        with open(plan, "w") as f:
            json.dump(PLAN, f)
        sweep = os.path.join(tmp, "sweep")
        subprocess.run([kfx, "sweep", plan, "--out", sweep, "--backend", "cpu",
                        "--idle-seconds", "0", "--commit", "test"], check=True,
                       stderr=subprocess.DEVNULL)
        try:
            import matplotlib  # noqa: F401
            plots = []
        except ImportError:
            plots = ["--no-plots"]
        out = os.path.join(tmp, "docs", "presets.md")
        os.makedirs(os.path.dirname(out))
        run = subprocess.run([sys.executable, script, sweep, "--out", out, "--command",
                              "kfx sweep plan.json"] + plots, capture_output=True, text=True)
        expect(run.returncode == 0, f"presets_report failed: {run.stderr}")
        page = open(out).read() if os.path.exists(out) else ""
        # Settings: computed from the configurations, exact's own differs in nothing.
        expect("| **exact** |" in page and "none (the baseline's configuration)" in page,
               "exact's settings row")
        expect("`pyramid_iterations=1`" in page and "`icp_stride_px=16`" in page,
               "fast's settings are the keys that differ from exact's")
        expect("`icp_robust=huber`" in page, "quality's settings")
        settings_section = page.split("## Settings")[-1].split("\n## ")[0]
        expect("unmarked" not in settings_section and "| **unmarked** |" not in page,
               "unmarked runs are not presets")
        expect("| unmarked |" in page, "every configuration's table lists unmarked runs too")
        # One row per preset with both sequences, and verdicts.
        rows = [line for line in page.splitlines() if line.startswith("| **fast** |")]
        expect(any("tracked" in r and r.count("frames/s") == 2 for r in rows),
               "fast's results row has both sequences")
        expect("`fast`: does NOT meet its constraint" in page,
               "the broken preset (1 ICP iteration, 16-pixel stride) is reported as failing")
        expect("`quality`: its constraint covers the real sequences, none here" in page,
               "quality's constraint is not judged on synthetic rooms")
        expect("Command: `kfx sweep plan.json`" in page, "the command is recorded")
        if not plots:
            for seq in ("room_a", "room_b"):
                png = os.path.join(tmp, "docs", "presets", f"pareto_cpu_{seq}.png")
                expect(os.path.exists(png) and os.path.getsize(png) > 1000, f"{png} written")
                expect(f"presets/pareto_cpu_{seq}.png" in page, f"{seq}'s plot linked")
        # Without the baseline: a clear error, no page.
        records = json.load(open(os.path.join(sweep, "results.json")))
        records["runs"] = [r for r in records["runs"] if r["name"] != "exact"]
        partial = os.path.join(tmp, "partial.json")
        json.dump(records, open(partial, "w"))
        bad_out = os.path.join(tmp, "bad.md")
        run = subprocess.run([sys.executable, script, partial, "--out", bad_out, "--no-plots"],
                             capture_output=True, text=True)
        expect(run.returncode != 0 and "no successful 'exact' run" in run.stderr,
               f"missing baseline is an error: {run.returncode} {run.stderr}")
        expect(not os.path.exists(bad_out), "no page written without the baseline")
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
