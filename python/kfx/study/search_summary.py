"""The summary of a search folder (kfx.study.search's trials.json, best.json, validation.json
and robustness.json) in a few lines: trials and feasible ones, the best configuration against
the baseline per sequence, the held-out and leave-one-out readings, robustness. scripts/gpu_search
prints it at the end of a round.

    python -m kfx.study.search_summary OUT_DIR

Pure standard library (it runs on the GPU machine).
"""

import json
import os
import sys

from . import run_tool


def load(out, name):
    """A JSON file of the folder, or None when absent."""
    path = os.path.join(out, name)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def summary_lines(out):
    """The summary of search folder `out`, as lines (none for an empty folder)."""
    lines = []
    trials, best, validation, robust = (load(out, n) for n in (
        "trials.json", "best.json", "validation.json", "robustness.json"))
    if trials:
        rows = trials["trials"]
        lines.append(f"trials: {len(rows)} ({sum(r['feasible'] for r in rows)} feasible)")
    if best:
        lines.append(f"best: trial {best['trial']}, {best['value']:.0f} frames/s (geomean), "
                     f"worst ATE ratio {best['worst_ate_ratio']}")
        lines.append("  " + best["set_arguments"])
        for s, r in best["results"].items():
            b = best["baseline"][s]
            lines.append(
                f"  {s}: {r.get('end_to_end_frames_per_second', 0):.0f} frames/s "
                f"(exact {b['end_to_end_frames_per_second']:.0f}), "
                f"ATE {r.get('ate_rmse_m', 0)*100:.2f} cm (exact {b['ate_rmse_m']*100:.2f}), "
                f"tracked {r.get('tracked')}/{r.get('frames')} (exact {b['tracked']})")
    if validation and validation.get("held_out"):
        h = validation["held_out"]
        verdict = "holds" if h["holds"] else "does NOT hold: " + ", ".join(h["reasons"])
        lines.append(f"held out: {verdict}; worst ATE ratio {h.get('worst_ate_ratio')}")
    if validation:
        for s, left in validation.get("leave_one_out", {}).items():
            verdict = ("holds" if left.get("holds_on_left_out")
                       else "fails " + ", ".join(left.get("reasons", [])))
            lines.append(f"leave {s} out: chose trial {left.get('chosen')}, on {s}: {verdict}")
    if robust:
        for c in robust["candidates"]:
            held = sum(n["holds"] for n in c["neighbours"])
            lines.append(f"robustness trial {c['trial']}: {held}/{len(c['neighbours'])} "
                         f"neighbours hold, start frames {c['start_frames'].get('holds')}, "
                         f"margin {c['margin']}")
        lines.append(f"preferred: trial {robust['preferred']}")
    return lines


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m kfx.study.search_summary OUT_DIR", file=sys.stderr)
        return 2
    for line in summary_lines(args[0]):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(run_tool("search_summary", main))
