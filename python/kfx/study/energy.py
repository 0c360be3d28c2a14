"""The energy table of scripts/energy_bench (bench/RESULTS.md): `kfx bench --json` results of
every sequence, preset and repeat (OUT/<seq>_<preset>_<rep>.json) as Markdown, gross mJ/frame
and frames/J, mean and idle W, the figures above idle, the run-to-run spread, and the host CPU's
energy where measured.

    python -m kfx.study.energy OUT --repeats 3 --idle-seconds 1.5 --presets "exact fast" \\
        --device "NVIDIA H200" --commit abc1234 --elapsed 168 icl_office_kt0 tum_fr1_xyz

Pure standard library (it runs on the GPU machine).
"""

import argparse
import datetime
import json
import os
import statistics
import sys

from . import ToolError, run_tool


def spread(values):
    """(max - min) / mean, in per cent: the run-to-run spread of repeated measurements."""
    m = statistics.mean(values)
    return 100.0 * (max(values) - min(values)) / m if m else float("nan")


def m(values, digits):
    """The mean with `digits` decimals, "–" for none."""
    return f"{statistics.mean(values):.{digits}f}" if values else "–"


def energy_table(out, sequences, presets, repeats, idle_s, device, commit, elapsed):
    """The Markdown table of the runs in folder `out`; `presets` a space-separated list.
    Raises ToolError when a run's JSON is missing or unreadable."""
    try:
        return _table(out, sequences, presets, repeats, idle_s, device, commit, elapsed)
    except (OSError, ValueError, KeyError) as e:
        raise ToolError(f"{out}: cannot read the bench results: {e}") from e


def _table(out, sequences, presets, repeats, idle_s, device, commit, elapsed):
    lines = [
        f"- Device: {device}, through this workplace's device tool. Date: "
        f"{datetime.date.today().isoformat()}. Commit: `{commit}`.",
        f"- Command: `scripts/energy_bench` ({elapsed} s): per row, `kfx bench /tmp/kfx_data/<seq>.raw "
        f"--backend cuda --preset <preset> --repeat <passes> --warmup 30 --idle-seconds {idle_s} "
        f"<sequence settings>`, {repeats} times.",
        "- Energy: the board's NVML energy counter (1 mJ ticks) over all timed passes of a run "
        "(the pipeline resets between passes included); the idle power is the same counter over "
        f"{idle_s} s before the warm-up, with kfx's CUDA context open, and is subtracted "
        "(idle W × the run's seconds) in the 'above idle' columns. Figures are the mean of the "
        f"{repeats} runs; spread = (max − min) / mean of the gross mJ/frame over those runs.",
        "",
        "| sequence | preset | frames × passes (s per run) | mJ/frame | frames/J | mean W | idle W | "
        "mJ/frame above idle | frames/J above idle | spread | method |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for seq in sequences:
        for preset in presets.split():
            runs = []
            for rep in range(1, repeats + 1):
                path = os.path.join(out, f"{seq}_{preset}_{rep}.json")
                with open(path) as f:
                    runs.append(json.load(f))
            gpu = [r["energy"]["gpu"] for r in runs]
            if not all(g.get("available") for g in gpu):
                reasons = sorted({g.get("reason", "?") for g in gpu if not g.get("available")})
                lines.append(f"| {seq} | {preset} | {runs[0]['frames']} × {runs[0]['repeat']} | "
                             f"{'; '.join(reasons)} | | | | | | | |")
                continue
            mj = [1e3 * g["joules_per_frame"] for g in gpu]
            fpj = [g["frames_per_joule"] for g in gpu]
            watts = [g["mean_watts"] for g in gpu]
            secs = [g["seconds"] for g in gpu]
            have_idle = all(g.get("idle") for g in gpu)
            idle = [g["idle"]["mean_watts"] for g in gpu] if have_idle else []
            above = [1e3 * g["above_idle_joules_per_frame"] for g in gpu] if have_idle else []
            above_fpj = [1.0 / (a * 1e-3) if a > 0 else float("nan") for a in above]
            methods = sorted({g["method"] for g in gpu})
            lines.append(
                f"| {seq} | {preset} | {runs[0]['frames']} × {runs[0]['repeat']} ({m(secs, 1)}) | "
                f"{m(mj, 3)} | {m(fpj, 1)} | {m(watts, 0)} | {m(idle, 0)} | {m(above, 3)} | "
                f"{m(above_fpj, 1)} | {spread(mj):.1f} % | {', '.join(methods)} |")
    with open(os.path.join(out, f"{sequences[0]}_{presets.split()[0]}_1.json")) as f:
        cpu = json.load(f)["energy"]["cpu"]
    if cpu.get("available"):
        lines += ["", f"Host CPU packages in the same run ({cpu['method']}, {cpu.get('source', '')}): "
                  f"{1e3 * cpu['joules_per_frame']:.3f} mJ/frame, {cpu['mean_watts']:.0f} W mean."]
    else:
        lines += ["", f"Host CPU energy on this machine: {cpu.get('reason', '?')}."]
    lines += ["", "Per run (JSON beside this file): gross mJ/frame, idle W:", ""]
    for seq in sequences:
        for preset in presets.split():
            values = []
            for rep in range(1, repeats + 1):
                with open(os.path.join(out, f"{seq}_{preset}_{rep}.json")) as f:
                    g = json.load(f)["energy"]["gpu"]
                if g.get("available"):
                    idle = g["idle"]["mean_watts"] if g.get("idle") else float("nan")
                    values.append(f"{1e3 * g['joules_per_frame']:.3f} ({idle:.0f} W idle)")
                else:
                    values.append(g.get("reason", "?"))
            lines.append(f"- {seq} {preset}: " + ", ".join(values))
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="folder of the kfx bench JSON files")
    parser.add_argument("sequences", nargs="+")
    parser.add_argument("--presets", required=True, help="space-separated, as measured")
    parser.add_argument("--repeats", type=int, required=True)
    parser.add_argument("--idle-seconds", required=True, help="as given to kfx bench")
    parser.add_argument("--device", default="unknown")
    parser.add_argument("--commit", default="unknown")
    parser.add_argument("--elapsed", default="?", help="seconds the measurements took")
    args = parser.parse_args(argv)
    print(energy_table(args.out, args.sequences, args.presets, args.repeats, args.idle_seconds,
                       args.device, args.commit, args.elapsed))
    return 0


if __name__ == "__main__":
    sys.exit(run_tool("energy_bench", main))
