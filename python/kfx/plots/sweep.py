#!/usr/bin/python3
"""Plots and tables of a `kfx sweep` (docs/sweep.md).

Reads DIR/results.json (or results.jsonl / results.csv) and writes into --out:
  step_<group>.png     one figure per step sweep: ATE, frames/s and the most affected stage's
                       time against the step, one line per sequence (the baseline run is the
                       first point when the sweep varies one setting over the baseline's preset)
  before_after.png     per-technique speed-up and ATE change against each run's `before` run
  presets_stages.png   per-stage time of the marked runs (presets), per sequence
  pareto.png           ATE against frames/s of every configuration, per sequence; marked runs
                       labelled, the Pareto front drawn
  tables.md            the per-technique before/after tables, the presets' stage table, the
                       Pareto front and any failed runs, as Markdown

With --report-template T --report OUT.md it also fills a Markdown template (placeholders below)
and keeps the text between <!-- reading:NAME --> and <!-- /reading:NAME --> that OUT.md already
holds, so hand-written readings survive regeneration.

Template placeholders:
  {{meta}}              device, backend, commit, dates, frames, repeat, command
  {{table:GROUP}}       the before/after table of one group     {{tables}}  all of them
  {{presets_table}}     per-stage table of the marked runs (thesis Table 4.6)
  {{pareto_table}}      the configurations on the Pareto front, per sequence
  {{failed}}            failed runs (empty when none)
  {{figure:NAME}}       an image link; NAME = step_<group>, before_after, presets_stages, pareto
  {{step_figures}}      every step figure
  {{results}}           links to the results files
  (more from --values-module: its extra_values(res, figures) returns {placeholder: text})

Run with /usr/bin/python3 (Debian's python3-matplotlib and numpy). Headless (Agg).
"""

import argparse
import csv
import json
import math
import os
import re
import sys

STAGES = ["preprocess", "track", "integrate", "raycast"]


def fail(message):
    print(f"plot_sweep.py: error: {message}", file=sys.stderr)
    sys.exit(2)


def import_pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        fail(
            f"matplotlib is not installed for {sys.executable}: install python3-matplotlib "
            "(Debian/Ubuntu) or `pip install matplotlib`, or use --no-plots for tables only"
        )
    return plt


# ------------------------------------------------------------------------------------------
# Loading.


def number_or_text(text):
    if text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        return text
    return int(value) if value.is_integer() and "." not in text and "e" not in text else value


def load_csv(path):
    """CSV rows as records (no "config": step plots then lack the baseline point)."""
    records = []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            r = {}
            stages = {}
            for key, text in row.items():
                m = re.fullmatch(r"(\w+)_ms_(mean|median)", key)
                if m and m.group(1) != "computation":
                    stages.setdefault(m.group(1), {})[m.group(2)] = number_or_text(text)
                elif key in ("computation_ms_mean", "computation_ms_median"):
                    r.setdefault("computation_ms", {})[key.rsplit("_", 1)[1]] = number_or_text(text)
                elif key in ("name", "group", "step", "step_key", "sequence", "backend", "status",
                             "preset", "before", "input", "device", "commit", "date", "error",
                             "energy_method", "energy_budget", "energy_note"):
                    r[key] = text
                elif key in ("baseline", "table", "mark"):
                    r[key] = text == "true"
                elif key == "settings":
                    r[key] = text.split(" ") if text else []
                else:
                    r[key] = number_or_text(text)
            r["stages_ms"] = stages
            records.append(r)
    return {"runs": records}


def load_results(path):
    if os.path.isdir(path):
        for name in ("results.json", "results.jsonl", "results.csv"):
            if os.path.exists(os.path.join(path, name)):
                path = os.path.join(path, name)
                break
        else:
            fail(f"{path}: no results.json, results.jsonl or results.csv in this folder")
    if not os.path.exists(path):
        fail(f"{path}: no such file")
    try:
        if path.endswith(".csv"):
            data = load_csv(path)
        elif path.endswith(".jsonl"):
            latest = {}
            with open(path) as f:
                for number, line in enumerate(f, 1):
                    if not line.strip():
                        continue
                    try:
                        r = json.loads(line)
                    except json.JSONDecodeError:
                        print(f"plot_sweep.py: skipping malformed line {number} of {path}",
                              file=sys.stderr)
                        continue
                    latest[(r.get("name"), r.get("sequence"), r.get("backend"))] = r
            data = {"runs": list(latest.values())}
        else:
            with open(path) as f:
                data = json.load(f)
    except (OSError, ValueError) as e:
        fail(f"{path}: cannot read results: {e}")
    if not isinstance(data, dict) or not isinstance(data.get("runs"), list):
        fail(f"{path}: not a kfx sweep results file (no 'runs' list)")
    data["source"] = path
    return data


class Results:
    """Records of one backend, indexed by (name, sequence)."""

    def __init__(self, data, backend):
        runs = data["runs"]
        backends = sorted({r.get("backend", "") for r in runs})
        if backend is None:
            if len(backends) > 1:
                fail(f"the results hold backends {', '.join(backends)}: pick one with --backend")
            backend = backends[0] if backends else ""
        elif backend not in backends:
            fail(f"no results for backend '{backend}' (have: {', '.join(backends)})")
        self.meta = data
        self.backend = backend
        self.all = [r for r in runs if r.get("backend", "") == backend]
        self.ok = [r for r in self.all if r.get("status") == "ok"]
        self.failed = [r for r in self.all if r.get("status") != "ok"]
        self.by_key = {(r["name"], r["sequence"]): r for r in self.ok}
        self.sequences = []
        for r in self.all:
            if r["sequence"] not in self.sequences:
                self.sequences.append(r["sequence"])
        self.names = []
        for r in self.all:
            if r["name"] not in self.names:
                self.names.append(r["name"])

        self.planned = []  # (name, group) of the plan's single named table runs (set_plan)

    def set_plan(self, plan):
        """Remembers the plan's single named runs (grids aside) that make table rows, so a row
        the results lack is listed as not measured instead of silently left out."""
        baseline = plan.get("baseline", "")
        for entry in plan.get("runs", []):
            name, group = entry.get("name"), entry.get("group")
            if not name or "grid" in entry or "{" in name:
                continue
            group = group or name
            before = entry.get("before", baseline if name != baseline else "")
            if entry.get("table", bool(before) and "step" not in entry) and before:
                self.planned.append((name, group))

    def planned_groups(self):
        return [g for _, g in self.planned]

    def planned_missing(self, group):
        return [n for n, g in self.planned if g == group and n not in self.names]

    def get(self, name, sequence):
        return self.by_key.get((name, sequence))

    def runs_named(self):
        """One record per name (the first), in order."""
        seen, out = set(), []
        for r in self.all:
            if r["name"] not in seen:
                seen.add(r["name"])
                out.append(r)
        return out


# ------------------------------------------------------------------------------------------
# Numbers.


def ate_cm(r):
    v = r.get("ate_rmse_m") if r else None
    return None if v is None else 100.0 * v


def checkpos_cm(r):
    v = r.get("checkpos_mean_m") if r else None
    return None if v is None else 100.0 * v


def diverged_text(r):
    """"N (first F, departs D)": frames beyond the divergence bound, the first of them and the
    departure frame (aligned on the frames up to it); "0"; or "n/m" when the record predates the
    measure (results of an older kfx)."""
    if not r or r.get("diverged_frames") is None:
        return "n/m"
    n = r["diverged_frames"]
    first, departure = r.get("first_diverged_frame"), r.get("departure_frame")
    parts = ([f"first {first}"] if n and first is not None else []) + (
        [f"departs {departure}"] if departure is not None else [])
    return f"{n} ({', '.join(parts)})" if parts else str(n)


def any_unmeasured_divergence(records):
    return any(r is not None and r.get("diverged_frames") is None for r in records)


DIVERGENCE_NOTE = ("\"> 10 cm\": frames whose position error after the rigid ATE alignment exceeds "
                   "10 cm (`kDivergenceBoundM`), the first of them, and the departure: the first "
                   "frame over 10 cm when aligned on the frames up to it only; n/m: not measured "
                   "in this results set (recorded by kfx sweep since the divergence measure was "
                   "added).")


def stage_ms(r, stage):
    try:
        return r["stages_ms"][stage]["mean"]
    except (KeyError, TypeError):
        return None


def computation_ms(r):
    try:
        return r["computation_ms"]["mean"]
    except (KeyError, TypeError):
        return None


def fmt(value, digits=2, suffix=""):
    if value is None:
        return "–"
    return f"{value:.{digits}f}{suffix}"


def fmt_ms(value):
    if value is None:
        return "–"
    return f"{value:.3f}" if value < 10 else f"{value:.1f}"


def speedup(before, after):
    b, a = computation_ms(before), computation_ms(after)
    return b / a if b and a else None


def most_changed_stage(before, after):
    """The stage whose mean time changed most (absolute), as (stage, before ms, after ms)."""
    best = None
    for stage in STAGES:
        b, a = stage_ms(before, stage), stage_ms(after, stage)
        if b is None or a is None:
            continue
        if best is None or abs(a - b) > abs(best[2] - best[1]):
            best = (stage, b, a)
    return best


def slug(text):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "group"


def as_number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


# ------------------------------------------------------------------------------------------
# Tables.


def table_groups(res):
    groups = []
    for r in res.runs_named():
        if r.get("table") and r.get("before") and r["group"] not in groups:
            groups.append(r["group"])
    for group in res.planned_groups():
        if group not in groups and res.planned_missing(group):
            groups.append(group)
    return groups


def before_after_table(res, group):
    lines = [
        "| configuration | sequence | ATE RMSE before → after (cm) | Δ ATE | ms/frame before → "
        "after | speed-up | frames/s after | stage most changed (ms) | tracked | > 10 cm |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    shown = []
    for named in res.runs_named():
        if named["group"] != group or not named.get("table") or not named.get("before"):
            continue
        for seq in res.sequences:
            after = res.get(named["name"], seq)
            before = res.get(named["before"], seq)
            shown += [after, before]
            if after is None:
                lines.append(f"| {named['name']} | {seq} | failed or missing | | | | | | | |")
                continue
            b_ate, a_ate = ate_cm(before), ate_cm(after)
            delta = None if b_ate is None or a_ate is None else a_ate - b_ate
            s = speedup(before, after)
            stage = most_changed_stage(before, after) if before else None
            stage_text = (f"{stage[0]} {fmt_ms(stage[1])} → {fmt_ms(stage[2])}" if stage else "–")
            lines.append(
                f"| {named['name']} | {seq} | {fmt(b_ate)} → {fmt(a_ate)} | "
                f"{'–' if delta is None else f'{delta:+.2f}'} | "
                f"{fmt_ms(computation_ms(before))} → {fmt_ms(computation_ms(after))} | "
                f"{fmt(s, 2, '×')} | {fmt(after.get('frames_per_second'), 0)} | {stage_text} | "
                f"{after.get('tracked', '–')}/{after.get('frames', '–')} | {diverged_text(after)} |"
            )
    for name in res.planned_missing(group):
        lines.append(f"| {name} | all | not measured in this results set | | | | | | | |")
    text = "\n".join(lines)
    if any_unmeasured_divergence(shown):
        text += "\n\n" + DIVERGENCE_NOTE
    return text


def marked_names(res):
    names = [r["name"] for r in res.runs_named() if r.get("mark")]
    return names


def presets_table(res):
    names = marked_names(res)
    if not names:
        return "_No marked runs (set `\"mark\": true` on the presets in the plan)._"
    baseline = next((r["name"] for r in res.runs_named() if r.get("baseline")), names[0])
    out = []
    for seq in res.sequences:
        runs = [(n, res.get(n, seq)) for n in names]
        base = res.get(baseline, seq)
        header = "| " + seq + " | " + " | ".join(n for n, _ in runs) + " |"
        lines = [header, "|---" * (len(runs) + 1) + "|"]

        def row(label, getter, formatter, ratio=False):
            cells = []
            for n, r in runs:
                v = getter(r) if r else None
                text = formatter(v)
                if ratio and r and base and n != baseline and v and getter(base):
                    text += f" (×{getter(base) / v:.2f})"
                cells.append(text)
            lines.append(f"| {label} | " + " | ".join(cells) + " |")

        for stage in STAGES:
            row(f"{stage} (ms/frame)", lambda r, s=stage: stage_ms(r, s), fmt_ms, ratio=True)
        row("computation (ms/frame)", computation_ms, fmt_ms, ratio=True)
        row("frames/s (1 / mean computation)", lambda r: r.get("frames_per_second"),
            lambda v: fmt(v, 0))
        row("frames/s end to end", lambda r: r.get("end_to_end_frames_per_second"),
            lambda v: fmt(v, 0))
        row("ATE RMSE, aligned (cm)", ate_cm, fmt)
        row("checkPos mean, unaligned (cm)", checkpos_cm, fmt)
        row("tracked frames", lambda r: r.get("tracked"), lambda v: "–" if v is None else str(v))
        row("frames > 10 cm (first, departure)", lambda r: r, diverged_text)
        out.append("\n".join(lines))
    note = (f"Speed-ups in brackets are against `{baseline}` (ratio of mean times). ATE RMSE is "
            "TUM-style (rigid alignment, then RMSE); checkPos mean is SLAMBench's unaligned "
            "per-frame error, the thesis's ATE divided by its frame count.")
    if any_unmeasured_divergence([res.get(n, s) for n in names for s in res.sequences]):
        note += " " + DIVERGENCE_NOTE
    return "\n\n".join(out) + "\n\n" + note


def pareto_front(points):
    """Points (fps, ate, ...) not dominated: no other point is at least as fast and as accurate
    and strictly better in one. Returned by decreasing frames/s."""
    front = []
    best_ate = math.inf
    for p in sorted(points, key=lambda p: (-p[0], p[1])):
        if p[1] < best_ate:
            front.append(p)
            best_ate = p[1]
    return front


def pareto_points(res, seq):
    """(fps, ATE, name, marked) of the sequence's runs; runs over the plan's energy budget
    (max_mj_per_frame, labelled by kfx sweep) are left out."""
    points = []
    for r in res.ok:
        if r["sequence"] != seq or r.get("energy_budget") == "over":
            continue
        fps, ate = r.get("frames_per_second"), ate_cm(r)
        if fps is not None and ate is not None:
            points.append((fps, ate, r["name"], bool(r.get("mark"))))
    return points


def pareto_table(res):
    out = []
    for seq in res.sequences:
        front = pareto_front(pareto_points(res, seq))
        over = sorted(r["name"] for r in res.ok
                      if r["sequence"] == seq and r.get("energy_budget") == "over")
        lines = [f"**{seq}**", "",
                 "| configuration | frames/s | ATE RMSE (cm) | > 10 cm | mJ/frame |",
                 "|---|---|---|---|---|"]
        for fps, ate, name, _ in front:
            run = res.get(name, seq)
            lines.append(f"| {name} | {fps:.0f} | {ate:.2f} | {diverged_text(run)} | "
                         f"{fmt(run.get('mj_per_frame'), 3)} |")
        if over:
            lines += ["", "Over the plan's energy budget, left out: " + ", ".join(over)]
        out.append("\n".join(lines))
    return "\n\n".join(out)


def failed_table(res):
    if not res.failed:
        return ""
    lines = ["| configuration | sequence | error |", "|---|---|---|"]
    for r in res.failed:
        error = str(r.get("error", "")).replace("|", "\\|").replace("\n", " ")
        lines.append(f"| {r['name']} | {r['sequence']} | {error} |")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# Figures.


def step_groups(res):
    groups = []
    for r in res.runs_named():
        if r.get("step") not in (None, "") and r["group"] not in groups:
            groups.append(r["group"])
    return groups


def step_series(res, group, seq):
    """[(step text, record)] of a step sweep on one sequence, the baseline first when the sweep
    varies only its step key over the baseline's preset."""
    runs = [r for r in res.ok if r["group"] == group and r["sequence"] == seq
            and r.get("step") not in (None, "")]
    series = [(r["step"], r) for r in runs]
    if not runs:
        return series
    key = runs[0].get("step_key", "")
    before = res.get(runs[0].get("before", ""), seq)
    only_step = all(r.get("settings") == [f"{key}={r['step']}"] for r in runs)
    same_preset = before is not None and all(r.get("preset") == before.get("preset") for r in runs)
    if only_step and same_preset and "config" in before and key in before["config"]:
        value = before["config"][key]
        if all(s != value for s, _ in series):
            series.insert(0, (value, before))
    if all(as_number(s) is not None for s, _ in series):
        series.sort(key=lambda item: as_number(item[0]))
    return series


def plot_step(plt, res, group, path):
    key = next((r.get("step_key") for r in res.all if r["group"] == group and r.get("step_key")),
               group)
    all_series = {seq: step_series(res, group, seq) for seq in res.sequences}
    all_series = {seq: s for seq, s in all_series.items() if s}
    if not all_series:
        return False
    numeric = all(as_number(s) is not None for series in all_series.values() for s, _ in series)
    categories = []
    if not numeric:
        for series in all_series.values():
            for s, _ in series:
                if s not in categories:
                    categories.append(s)

    def x_of(step):
        return as_number(step) if numeric else categories.index(step)

    # Top row: ATE and frames/s against the step, one line per sequence. Bottom row: where the
    # time goes at each step (stacked stage times), one panel per sequence.
    n = max(2, len(all_series))
    top = ["ate"] * ((n + 1) // 2) + ["fps"] * (n // 2)
    bottom = [f"s{i}" for i in range(len(all_series))]
    bottom += [bottom[-1]] * (n - len(bottom))
    fig, ax = plt.subplot_mosaic([top, bottom], figsize=(6.5 * n, 8))
    for seq, series in all_series.items():
        xs = [x_of(s) for s, _ in series]
        ax["ate"].plot(xs, [ate_cm(r) for _, r in series], "o-", label=seq)
        ax["fps"].plot(xs, [r.get("frames_per_second") for _, r in series], "o-", label=seq)
    for name, title in (("ate", "ATE RMSE (cm)"), ("fps", "frames/s (1 / mean computation time)")):
        ax[name].set_title(title)
        ax[name].set_xlabel(key)
        ax[name].grid(True, alpha=0.3)
        ax[name].set_ylim(bottom=0)
        if not numeric:
            ax[name].set_xticks(range(len(categories)))
            ax[name].set_xticklabels(categories)
    ax["ate"].legend()
    for i, (seq, series) in enumerate(all_series.items()):
        a = ax[f"s{i}"]
        labels = [s for s, _ in series]
        base = [0.0] * len(series)
        for stage in STAGES:
            values = [stage_ms(r, stage) or 0.0 for _, r in series]
            a.bar(range(len(series)), values, bottom=base, label=stage)
            base = [b + v for b, v in zip(base, values)]
        a.set_xticks(range(len(series)))
        a.set_xticklabels(labels)
        a.set_xlabel(key)
        a.set_ylabel("ms per frame (mean)")
        a.set_title(f"{seq}: time per stage")
        a.grid(True, axis="y", alpha=0.3)
        if i == 0:
            a.legend(fontsize=8)
    fig.suptitle(f"{group}: {key} step sweep ({res.backend})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def plot_before_after(plt, res, path):
    rows = [r for r in res.runs_named() if r.get("table") and r.get("before")]
    if not rows:
        return False
    import numpy as np

    seqs = res.sequences
    height = 0.8 / max(1, len(seqs))
    fig, axes = plt.subplots(1, 2, figsize=(14, 1.0 + 0.42 * len(rows) * max(1, len(seqs)) / 1.5),
                             sharey=True)
    y = np.arange(len(rows))
    for i, seq in enumerate(seqs):
        speed, delta = [], []
        for named in rows:
            after, before = res.get(named["name"], seq), res.get(named["before"], seq)
            s = speedup(before, after) if after and before else None
            speed.append(s if s is not None else 0.0)
            b, a = ate_cm(before), ate_cm(after)
            delta.append(a - b if a is not None and b is not None else 0.0)
        offset = (i - (len(seqs) - 1) / 2) * height
        axes[0].barh(y + offset, speed, height, label=seq)
        axes[1].barh(y + offset, delta, height, label=seq)
    axes[0].axvline(1.0, color="black", linewidth=0.8)
    axes[1].axvline(0.0, color="black", linewidth=0.8)
    axes[0].set_yticks(y)
    axes[0].set_yticklabels([f"{r['name']}  (vs {r['before']})" for r in rows], fontsize=8)
    axes[0].invert_yaxis()
    axes[0].set_title("speed-up of mean computation time (×)")
    axes[1].set_title("ATE RMSE change (cm; negative = better)")
    for ax in axes:
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].legend(loc="lower right")
    fig.suptitle(f"each technique against its baseline ({res.backend})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def plot_presets(plt, res, path):
    names = marked_names(res)
    if not names:
        return False
    fig, axes = plt.subplots(1, len(res.sequences), figsize=(5.5 * len(res.sequences), 4.2),
                             squeeze=False)
    for ax, seq in zip(axes[0], res.sequences):
        bottom = [0.0] * len(names)
        for stage in STAGES:
            values = [stage_ms(res.get(n, seq), stage) or 0.0 for n in names]
            ax.bar(names, values, bottom=bottom, label=stage)
            bottom = [b + v for b, v in zip(bottom, values)]
        for i, n in enumerate(names):
            r = res.get(n, seq)
            if r:
                ax.text(i, bottom[i], f"{r.get('frames_per_second', 0):.0f} f/s\n"
                        f"ATE {fmt(ate_cm(r))} cm", ha="center", va="bottom", fontsize=8)
        ax.set_title(seq)
        ax.set_ylabel("ms per frame (mean)")
        ax.set_ylim(top=max(bottom + [1e-9]) * 1.3)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0][0].legend()
    fig.suptitle(f"where the time goes, per preset ({res.backend})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def plot_pareto(plt, res, path):
    fig, axes = plt.subplots(1, len(res.sequences), figsize=(6.5 * len(res.sequences), 5),
                             squeeze=False)
    any_points = False
    for ax, seq in zip(axes[0], res.sequences):
        points = pareto_points(res, seq)
        if not points:
            ax.set_title(f"{seq}: no results")
            continue
        any_points = True
        ax.scatter([p[0] for p in points], [p[1] for p in points], s=14, color="0.6",
                   label="configurations", zorder=2)
        front = pareto_front(points)
        ax.step([p[0] for p in front], [p[1] for p in front], where="post", color="tab:red",
                linewidth=1.2, label="Pareto front", zorder=3)
        ax.scatter([p[0] for p in front], [p[1] for p in front], s=22, color="tab:red", zorder=4)
        for fps, ate, name, marked in points:
            if marked:
                ax.scatter([fps], [ate], s=90, marker="*", color="tab:blue", zorder=5)
                ax.annotate(name, (fps, ate), textcoords="offset points", xytext=(6, 6),
                            fontsize=9, color="tab:blue", weight="bold")
        fps_values = [p[0] for p in points]
        if min(fps_values) > 0 and max(fps_values) / min(fps_values) > 10:
            ax.set_xscale("log")
        ax.set_xlabel("frames/s (1 / mean computation time)")
        ax.set_ylabel("ATE RMSE (cm)")
        ax.set_title(seq)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(f"accuracy against speed, every configuration ({res.backend}); "
                 "stars: presets")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return any_points


# ------------------------------------------------------------------------------------------
# Report.


def meta_text(res, command):
    runs = res.all
    devices = sorted({r.get("device", "") for r in res.ok if r.get("device")})
    commits = sorted({r.get("commit", "") for r in runs if r.get("commit")})
    dates = sorted(r.get("date", "") for r in runs if r.get("date"))
    frames = sorted({(r["sequence"], r.get("frames")) for r in res.ok})
    repeats = sorted({r.get("repeat") for r in runs if r.get("repeat") is not None})
    lines = [
        f"- backend: `{res.backend}`; device: {', '.join(devices) or 'unknown'}",
        f"- commit: {', '.join(f'`{c}`' for c in commits) or 'unknown'}; run between "
        f"{dates[0] if dates else '?'} and {dates[-1] if dates else '?'}",
        f"- sequences: {', '.join(f'{s} ({n} frames)' for s, n in frames)}",
        f"- {len(res.ok)} runs succeeded, {len(res.failed)} failed; timed passes per run: "
        f"{', '.join(str(x) for x in repeats) or '?'}; per-stage times are means over frames "
        "and passes, frames/s = 1000 / mean computation ms",
    ]
    if command:
        lines.append(f"- made by: `{command}`")
    return "\n".join(lines)


READING = re.compile(r"<!-- reading:([A-Za-z0-9_.-]+) -->(.*?)<!-- /reading:\1 -->", re.S)


def fill_template(template, values, existing):
    kept = {m.group(1): m.group(2) for m in READING.finditer(existing or "")}

    def keep(m):
        body = kept.get(m.group(1))
        if body is None or not body.strip():
            body = m.group(2)
        return f"<!-- reading:{m.group(1)} -->{body}<!-- /reading:{m.group(1)} -->"

    def substitute(m):
        key = m.group(1)
        if key in values:
            return values[key]
        if key.startswith("table:"):
            return f"_No before/after table for group '{key[6:]}' in these results._"
        if key.startswith("figure:"):
            return f"_No figure '{key[7:]}' for these results._"
        fail(f"template placeholder {{{{{key}}}}} is unknown")

    text = re.sub(r"\{\{([^{}]+)\}\}", substitute, template)
    return READING.sub(keep, text)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("results", help="sweep folder, or its results.json/.jsonl/.csv")
    parser.add_argument("--out", help="folder for PNGs and tables.md (default: RESULTS folder)")
    parser.add_argument("--backend", help="which backend's results (needed when several)")
    parser.add_argument("--no-plots", action="store_true", help="tables only (no matplotlib)")
    parser.add_argument("--report-template", help="Markdown template to fill (see above)")
    parser.add_argument("--report", help="Markdown report to write from --report-template")
    parser.add_argument("--command", default="", help="command line to cite in {{meta}}")
    parser.add_argument("--plan", help="the sweep plan: its table runs missing from the results "
                        "are listed as not measured")
    parser.add_argument("--values-module", help="Python file whose extra_values(res, figures) "
                        "returns more template placeholders (e.g. scripts/thesis_report.py)")
    args = parser.parse_args()
    if bool(args.report) != bool(args.report_template):
        fail("--report and --report-template go together")

    data = load_results(args.results)
    res = Results(data, args.backend)
    if not res.all:
        fail(f"{data['source']}: no runs")
    if args.plan:
        try:
            with open(args.plan) as f:
                res.set_plan(json.load(f))
        except (OSError, ValueError) as e:
            fail(f"{args.plan}: cannot read the plan: {e}")
    out = args.out or os.path.dirname(os.path.abspath(data["source"]))
    os.makedirs(out, exist_ok=True)

    figures = {}
    if not args.no_plots:
        plt = import_pyplot()
        for group in step_groups(res):
            path = os.path.join(out, f"step_{slug(group)}.png")
            if plot_step(plt, res, group, path):
                figures[f"step_{group}"] = (path, f"{group}: ATE and speed against the step")
        for name, function, caption in (
            ("before_after", plot_before_after, "each technique against its baseline"),
            ("presets_stages", plot_presets, "per-stage time of the presets"),
            ("pareto", plot_pareto, "ATE against frames/s, all configurations"),
        ):
            path = os.path.join(out, f"{name}.png")
            if function(plt, res, path):
                figures[name] = (path, caption)

    tables = {g: before_after_table(res, g) for g in table_groups(res)}
    sections = [f"# Sweep tables ({res.backend})", "", meta_text(res, args.command), ""]
    for group, table in tables.items():
        sections += [f"## {group}", "", table, ""]
    sections += ["## presets: per-stage time", "", presets_table(res), "", "## Pareto front", "",
                 pareto_table(res), ""]
    if res.failed:
        sections += ["## failed runs", "", failed_table(res), ""]
    tables_path = os.path.join(out, "tables.md")
    with open(tables_path, "w") as f:
        f.write("\n".join(sections))

    written = [tables_path] + [p for p, _ in figures.values()]
    if args.report:
        report_dir = os.path.dirname(os.path.abspath(args.report))

        def link(name):
            path, caption = figures[name]
            return f"![{caption}]({os.path.relpath(path, report_dir)})"

        values = {
            "meta": meta_text(res, args.command),
            "tables": "\n\n".join(f"**{g}**\n\n{t}" for g, t in tables.items()),
            "presets_table": presets_table(res),
            "pareto_table": pareto_table(res),
            "failed": failed_table(res) or "None.",
            "step_figures": "\n\n".join(link(n) for n in figures if n.startswith("step_")),
            "results": ", ".join(
                f"[{os.path.basename(p)}]({os.path.relpath(p, report_dir)})"
                for p in [data["source"], os.path.splitext(data["source"])[0] + ".csv",
                          tables_path] if os.path.exists(p)),
        }
        values.update({f"table:{g}": t for g, t in tables.items()})
        values.update({f"figure:{n}": link(n) for n in figures})
        if args.values_module:
            import importlib.util

            spec = importlib.util.spec_from_file_location("values_module", args.values_module)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            values.update(module.extra_values(res, figures))
        with open(args.report_template) as f:
            template = f.read()
        existing = open(args.report).read() if os.path.exists(args.report) else ""
        text = fill_template(template, values, existing)
        tmp = args.report + ".partial"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, args.report)
        written.append(args.report)
    for path in written:
        print(path)


if __name__ == "__main__":
    main()
