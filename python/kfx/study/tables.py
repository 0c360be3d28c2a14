"""Markdown from `kfx sweep` results (kfx.study.results): the per-technique before/after
tables, the presets' per-stage table, the Pareto front, failed runs, the run's provenance, and
a report template filled from placeholders (docs/sweep.md, "Plots and tables").

Pure standard library.
"""

import re

from . import ToolError
from .results import (DIVERGENCE_NOTE, STAGES, any_unmeasured_divergence, ate_cm, checkpos_cm,
                      computation_ms, diverged_text, most_changed_stage, pareto_front,
                      pareto_points, speedup, stage_ms)


def fail(message):
    raise ToolError(message)


def fmt(value, digits=2, suffix=""):
    if value is None:
        return "–"
    return f"{value:.{digits}f}{suffix}"


def fmt_ms(value):
    if value is None:
        return "–"
    return f"{value:.3f}" if value < 10 else f"{value:.1f}"


def slug(text):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "group"


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
