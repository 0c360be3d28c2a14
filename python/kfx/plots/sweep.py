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

Command: scripts/plot_sweep.py, or `python -m kfx.plots.sweep` where the package is installed.
The figures need matplotlib and numpy (Debian: python3-matplotlib; run with /usr/bin/python3),
headless (Agg); --no-plots writes the tables without them.
"""

import argparse
import json
import os
import sys

from ..study import ToolError, run_tool
from ..study.results import (STAGES, Results, as_number, ate_cm, load_results, pareto_front,
                             pareto_points, speedup, stage_ms, step_groups, step_series)
from ..study.tables import (before_after_table, failed_table, fill_template, fmt, marked_names,
                            meta_text, pareto_table, presets_table, slug, table_groups)
from . import import_pyplot


def fail(message):
    raise ToolError(message)


# ------------------------------------------------------------------------------------------
# Figures.


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


def values_module(name):
    """A module by file path (a .py file) or by name (kfx.study.thesis)."""
    import importlib
    import importlib.util

    if not (name.endswith(".py") or os.sep in name):
        return importlib.import_module(name)
    spec = importlib.util.spec_from_file_location("values_module", name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv=None):
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
    parser.add_argument("--values-module", help="Python file or module whose "
                        "extra_values(res, figures) returns more template placeholders "
                        "(e.g. kfx.study.thesis)")
    args = parser.parse_args(argv)
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
            values.update(values_module(args.values_module).extra_values(res, figures))
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
    sys.exit(run_tool("plot_sweep.py", main))
