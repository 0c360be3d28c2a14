"""The readings and the side-by-side tables of docs/thesis-study.md, computed from the results.

Loaded by kfx.plots.sweep (--values-module kfx.study.thesis) when scripts/thesis_study writes the
report:
extra_values(res, figures) returns the placeholders {{reading:SECTION}} and
{{thesis_table:SECTION}}. Every number in the text comes from the sweep results (`res`) or from
docs/thesis-study/thesis_tables.json (the thesis's own tables, typed once with their source);
every comparison ("breaks", "faster", "between X and Y") is a condition evaluated on them, so
regenerating from other results keeps the text true. A run the results lack is said to be
"not measured in this results set".
"""

import json
import os

from . import ToolError, default_path
from .results import STAGES, ate_cm, computation_ms, stage_ms

# A run "breaks" a sequence when its ATE RMSE exceeds the divergence bound (then frames lie
# beyond it) or, where the divergence measure was recorded, more than this share of its frames
# lie beyond the bound.
BOUND_CM = 10.0
BROKEN_FRAME_SHARE = 0.05
NOT_MEASURED = "not measured in this results set"
# The thesis's tables: the checkout's copy (KFX_THESIS_TABLES names another).
THESIS_TABLES = os.environ.get("KFX_THESIS_TABLES",
                               default_path("docs", "thesis-study", "thesis_tables.json"))
SHORT = {"icl_office_kt0": "ICL", "tum_fr1_xyz": "TUM"}


# ------------------------------------------------------------------------------------------
# Small formatters and facts.


def cm(v):
    return "–" if v is None else f"{v:.2f} cm"


def ms(v):
    return "–" if v is None else f"{v:.3f} ms"


def times(v):
    return "–" if v is None else f"×{v:.2f}"


def pct(v):
    return "–" if v is None else f"{v:+.0f} %"


def short(seq):
    return SHORT.get(seq, seq)


def ratio(a, b):
    return a / b if a and b else None


def broken(r):
    """Whether a run left the ground truth (see BOUND_CM)."""
    a = ate_cm(r)
    if a is not None and a > BOUND_CM:
        return True
    n, frames = r.get("diverged_frames"), r.get("frames")
    return bool(n is not None and frames and n > BROKEN_FRAME_SHARE * frames)


def divergence_phrase(r):
    n = r.get("diverged_frames")
    if n is None:
        return "frames beyond 10 cm not measured"
    if n == 0 and r.get("departure_frame") is None:
        return "no frame beyond 10 cm"
    text = f"{n} frames beyond 10 cm"
    if r.get("first_diverged_frame") is not None:
        text += f", the first at frame {r['first_diverged_frame']}"
    if r.get("departure_frame") is not None:
        text += (f"; it leaves the ground truth at frame {r['departure_frame']} (aligned on the "
                 "frames up to it)")
    return text


def state(r):
    """"0.83 cm, 496/500 tracked" (+ divergence when measured)."""
    text = f"{cm(ate_cm(r))}, {r.get('tracked')}/{r.get('frames')} tracked"
    if r.get("diverged_frames") is not None:
        text += f", {divergence_phrase(r)}"
    return text


class Facts:
    """Lookups on the results against the baseline run."""

    def __init__(self, res):
        self.res = res
        self.seqs = res.sequences
        self.base = next((r["name"] for r in res.runs_named() if r.get("baseline")), "exact")

    def get(self, name, seq):
        return self.res.get(name, seq)

    def measured(self, name):
        return all(self.get(name, s) is not None for s in self.seqs)

    def frame_speedup(self, name, seq, before=None):
        return ratio(computation_ms(self.get(before or self.base, seq)),
                     computation_ms(self.get(name, seq)))

    def stage_speedup(self, name, seq, stage, before=None):
        return ratio(stage_ms(self.get(before or self.base, seq), stage),
                     stage_ms(self.get(name, seq), stage))

    def ate_delta(self, name, seq, before=None):
        a, b = ate_cm(self.get(name, seq)), ate_cm(self.get(before or self.base, seq))
        return None if a is None or b is None else a - b

    def stage_changes(self, name, seq, before=None, min_ms=0.005):
        """"integrate −0.029 ms, track +0.021 ms": every stage that moved by min_ms or more."""
        b, a = self.get(before or self.base, seq), self.get(name, seq)
        parts = []
        for stage in STAGES:
            x, y = stage_ms(b, stage), stage_ms(a, stage)
            if x is not None and y is not None and abs(y - x) >= min_ms:
                parts.append(f"{stage} {y - x:+.3f} ms")
        return ", ".join(parts) or "no stage moved by 0.005 ms or more"

    def per_seq(self, name, describe, before=None):
        """"ICL: ...; TUM: ..." with describe(record, seq), or NOT_MEASURED."""
        parts = []
        for seq in self.seqs:
            r = self.get(name, seq)
            parts.append(f"{short(seq)}: {describe(r, seq) if r else NOT_MEASURED}")
        return "; ".join(parts)

    def technique(self, name, stage=None, before=None):
        """One run against its baseline, per sequence: speed-ups, stage, ATE, state."""
        if not any(self.get(name, s) for s in self.seqs):
            return f"`{name}`: {NOT_MEASURED}"

        def describe(r, seq):
            text = f"frame {times(self.frame_speedup(name, seq, before))}"
            if stage:
                b = stage_ms(self.get(before or self.base, seq), stage)
                text += f", {stage} {ms(b)} → {ms(stage_ms(r, stage))}"
            d = self.ate_delta(name, seq, before)
            text += f", ATE {cm(ate_cm(self.get(before or self.base, seq)))} → {cm(ate_cm(r))}"
            text += f" ({'breaks: ' if broken(r) else ''}{r.get('tracked')}/{r.get('frames')} tracked"
            if r.get("diverged_frames") is not None:
                text += f", {divergence_phrase(r)}"
            text += ")"
            return text if d is not None else text

        return f"`{name}`: " + self.per_seq(name, describe, before)

    def step_summary(self, group, seq):
        """The step runs of a group on one sequence, split into those that hold and those that
        break: ("2: 0.92 cm, 4: 1.42 cm", "8: 143.10 cm, ...")."""
        runs = [r for r in self.res.ok if r["group"] == group and r["sequence"] == seq
                and r.get("step") not in (None, "")]

        def key(r):
            try:
                return float(r["step"])
            except ValueError:
                return 0.0

        runs.sort(key=key)
        ok = [f"{r['step']}: {cm(ate_cm(r))}" for r in runs if not broken(r)]
        bad = [f"{r['step']}: {cm(ate_cm(r))}, {r.get('tracked')}/{r.get('frames')} tracked"
               + (f", {r['diverged_frames']} beyond 10 cm" if r.get('diverged_frames') is not None
                  else "") for r in runs if broken(r)]
        return ok, bad, runs

    def step_sentence(self, group, what):
        if not any(r["group"] == group for r in self.res.ok):
            return f"{what}: {NOT_MEASURED}."
        parts = []
        for seq in self.seqs:
            ok, bad, runs = self.step_summary(group, seq)
            if not runs:
                parts.append(f"on {short(seq)} {NOT_MEASURED}")
                continue
            text = f"on {short(seq)} "
            text += f"holds at {'; '.join(ok)}" if ok else "holds at no step"
            text += f" and breaks at {'; '.join(bad)}" if bad else ", and breaks at no step"
            parts.append(text)
        return f"{what}: " + "; ".join(parts) + "."


# ------------------------------------------------------------------------------------------
# Readings.


def reading_presets(f, thesis):
    final = next(t for t in thesis["techniques"] if t["id"] == "final")
    lines = []
    if not f.measured("thesis"):
        return f"`thesis`: {NOT_MEASURED}."
    dev = sorted({r.get("device", "") for r in f.res.ok if r.get("device")})
    lines.append(f"**Reading.** Measured on {', '.join(dev) or 'an unknown device'} "
                 f"(`{f.res.backend}` backend).")
    sp = [f.frame_speedup("thesis", s) for s in f.seqs]
    t_fps = final["fps"]
    lines.append(
        "`thesis` is " + " and ".join(f"{times(v)} on {short(s)}" for v, s in zip(sp, f.seqs))
        + f" per frame against `{f.base}`; the thesis's Table 4.6 has {t_fps[0]} → {t_fps[1]} "
        f"frames/s ({times(final['frame_s'][0] / final['frame_s'][1])} in total time) on a "
        f"{thesis['device']}.")
    for seq in f.seqs:
        r, b = f.get("thesis", seq), f.get(f.base, seq)
        if broken(r):
            lines.append(f"On {seq} it breaks: ATE {cm(ate_cm(b))} → {cm(ate_cm(r))} although "
                         f"{r.get('tracked')} of {r.get('frames')} frames count as tracked "
                         f"({divergence_phrase(r)}).")
        else:
            lines.append(f"On {seq} it holds: ATE {cm(ate_cm(b))} → {cm(ate_cm(r))} "
                         f"({r.get('tracked')}/{r.get('frames')} tracked; "
                         f"{divergence_phrase(r)}).")
    ta = final["ate"]
    lines.append(f"The thesis reported {ta[0]} → {ta[1]} m of summed unaligned error on its "
                 f"living-room sequence ({pct(100 * (ta[1] / ta[0] - 1))}).")
    factors = {n: f.get(n, f.seqs[0]).get("config", {}).get("ray_factor")
               for n in ("exact", "thesis", "fast") if f.get(n, f.seqs[0])}
    if any(factors.values()):
        lines.append("Ray factor used by each preset in these results: "
                     + ", ".join(f"`{n}`: `{v}`" for n, v in factors.items()) + ".")
    if f.measured("fast"):
        faster = [s for s in f.seqs if f.get("fast", s)["frames_per_second"]
                  > f.get("thesis", s)["frames_per_second"]]
        within = [s for s in f.seqs if ate_cm(f.get("fast", s)) <= 1.1 * ate_cm(f.get(f.base, s))]
        fps = "; ".join(f"{short(s)} {f.get('fast', s)['frames_per_second']:.0f} against "
                        f"{f.get('thesis', s)['frames_per_second']:.0f} frames/s" for s in f.seqs)
        lines.append(
            f"`fast` is faster than `thesis` on {len(faster)} of {len(f.seqs)} sequences ({fps}) "
            f"and keeps ATE within 10 % of `{f.base}` on {len(within)} of them ("
            + "; ".join(f"{short(s)} {cm(ate_cm(f.get('fast', s)))} against "
                        f"{cm(ate_cm(f.get(f.base, s)))}" for s in f.seqs) + ").")
        base_cfg = f.get(f.base, f.seqs[0]).get("config", {})
        fast_cfg = f.get("fast", f.seqs[0]).get("config", {})
        diff = [f"`{k}={v}`" for k, v in sorted(fast_cfg.items()) if base_cfg.get(k) != v]
        if diff:
            lines.append("It differs from `exact` in " + ", ".join(diff) + "; no run of this "
                         "set varies one of them alone within `fast`, so which of them matters "
                         "most is not measured here.")
    return "\n".join(lines)


def reading_bilateral(f, thesis):
    t = next(t for t in thesis["techniques"] if t["id"] == "bilateral")
    lines = ["**Reading.**"]
    for name in ("bilateral: 3x3 spatial only", "bilateral: zero-padded depth",
                 "bilateral: 3x3 + zero padding (thesis)"):
        lines.append(f.technique(name, "preprocess") + ".")
    ts = t["stage_s"]
    lines.append(f"The thesis's preprocessing went {ts[0]} → {ts[1]} s "
                 f"({times(ts[0] / ts[1])}, its Table 4.1), its frame "
                 f"{times(t['frame_s'][0] / t['frame_s'][1])}.")
    return "\n".join(lines)


def reading_tracking(f, thesis):
    t = next(t for t in thesis["techniques"] if t["id"] == "tracking")
    lines = ["**Reading.**", f.technique("tracking: 1 level, 2 iterations (thesis)", "track") + "."]
    ts = t["stage_s"]
    lines.append(f"The thesis's tracking went {ts[0]} → {ts[1]} s ({times(ts[0] / ts[1])}), its "
                 f"frame {times(t['frame_s'][0] / t['frame_s'][1])} (Table 4.2).")
    # The pyramid step sweep: the fastest configuration that keeps ATE within 10 % of exact.
    for seq in f.seqs:
        b = f.get(f.base, seq)
        runs = [r for r in f.res.ok if r["group"] == "pyramid_iterations" and r["sequence"] == seq]
        if not runs or not b:
            continue
        good = [r for r in runs if ate_cm(r) <= 1.1 * ate_cm(b)]
        text = f"Pyramid iterations on {short(seq)}: " + ", ".join(
            f"`{r['step']}` {times(f.frame_speedup(r['name'], seq))} at {cm(ate_cm(r))}"
            for r in runs) + "."
        if good:
            best = max(good, key=lambda r: r["frames_per_second"])
            text += (f" The fastest within 10 % of `{f.base}`'s ATE is `{best['step']}` "
                     f"({times(f.frame_speedup(best['name'], seq))}).")
        lines.append(text)
    for name in ("tracking: ICP stride 2", "tracking: ICP stride 4"):
        lines.append(f.technique(name, "track") + ".")
    strides = [f.stage_speedup(n, s, "track") for n in ("tracking: ICP stride 2",
                                                         "tracking: ICP stride 4")
               for s in f.seqs]
    if strides and all(v is not None and v < 1.1 for v in strides):
        lines.append("ICP pixel stride (the tracking perforation the thesis tried and dropped) "
                     "shortens the track stage by less than 10 % here: an ICP iteration on "
                     "320×240 is bound by its fixed costs (launches, the reduction, the 6×6 "
                     "solve), not by the pixels it visits; that is a reading of these numbers, "
                     "not measured separately.")
    return "\n".join(lines)


def reading_integrate(f, thesis):
    lines = ["**Reading.**"]
    t31 = thesis["table_3_1"]
    share_t = 100 * t31["stages_s"]["integrate"] / t31["computation_s"]
    shares = []
    for seq in f.seqs:
        b = f.get(f.base, seq)
        if b:
            i, c = stage_ms(b, "integrate"), computation_ms(b)
            shares.append(f"{ms(i)} of {ms(c)} on {short(seq)} ({100 * i / c:.0f} %)")
    lines.append(f"Integration in `{f.base}` takes " + " and ".join(shares) +
                 f" of the computation; in the thesis's Table 3.1 it is {t31['stages_s']['integrate']}"
                 f" of {t31['computation_s']} s ({share_t:.0f} %).")
    name = "integrate: z stride 16 (thesis alone)"
    lines.append(f.technique(name, "integrate") + ".")
    if f.measured(name):
        lines.append("Where the time went with stride 16: " + "; ".join(
            f"{short(s)}: {f.stage_changes(name, s)}" for s in f.seqs) + ".")
    lines.append(f.step_sentence("integration_z_stride", "The z-stride sweep"))
    lines.append(f.step_sentence("integration_checker_stride",
                                 "The 3-D checkerboard pattern at the same rates (ours)"))
    for n in ("integrate: ray factor approx", "integrate: ray factor thesis",
              "integrate: ray factor none", "integrate: no depth-0 test"):
        lines.append(f.technique(n, "integrate") + ".")
    lines.append("No per-frame trajectory is kept in these results; when a run leaves the "
                 "ground truth is its departure frame, where measured (above).")
    return "\n".join(lines)


def reading_raycast(f, thesis):
    lines = ["**Reading.**"]
    pair = "raycast: constant step + 2-value interpolation"
    lines.append(f.technique(pair, "raycast") + ".")
    if f.measured(pair):
        bad = [s for s in f.seqs if broken(f.get(pair, s))]
        if bad:
            lines.append("So the pair the thesis evaluated as one breaks "
                         + ", ".join(bad) + ": " + "; ".join(
                             f"{cm(ate_cm(f.get(pair, s)))}, {f.get(pair, s)['tracked']} of "
                             f"{f.get(pair, s)['frames']} tracked" for s in bad) + ".")
        else:
            lines.append("The pair the thesis evaluated as one holds on every sequence here.")
    for n in ("raycast: constant step 0.075 m", "raycast: 2-value interpolation",
              "raycast: 2x2 blocks (thesis)", "raycast: every 2nd frame (thesis)",
              "raycast: 2x2 blocks + every 2nd frame (thesis final)",
              "raycast: all three together (thesis Table 4.5)"):
        lines.append(f.technique(n, "raycast") + ".")
    lines.append(f.step_sentence("raycast_block_px", "Block sizes"))
    lines.append(f.step_sentence("raycast_rate", "Raycast rates"))
    lines.append(f.step_sentence("raycast_constant_step_m", "Constant steps (m)"))
    lines.append("kfx's blocks are explicit: `raycast_block_px=bx,by` casts one ray per bx×by "
                 "block and copies it into the block. The thesis's text says \"Block 1x2\" "
                 "(Section 4.1.4), its code copies 2×2; the `thesis` preset and the rows marked (thesis) "
                 "use 2×2, because the preset reproduces the code that produced the thesis's "
                 "Table 4.6, and the block sweep above measures 1×2 and 2×1 as well.")
    return "\n".join(lines)


def reading_combining(f, thesis):
    lines = ["**Reading.**", f.technique("IT: integrate + tracking (thesis)", "integrate") + "."]
    lines.append(f.step_sentence("bit_integration_z_stride",
                                 "BIT (bilateral + tracking changes) over the z stride; the "
                                 "thesis chose 12 here"))
    lines.append(f.step_sentence("thesis_integration_z_stride",
                                 "The whole `thesis` preset over the z stride; the thesis chose 8"))
    return "\n".join(lines)


def reading_size(f, thesis):
    lines = ["**Reading.**"]
    pairs = [("size: compute ratio 2", "raycast"), ("size: compute ratio 2 + 2x2 blocks", "raycast"),
             ("size: 512^3 volume", "integrate"), ("size: 512^3 volume + 2x2 blocks", "raycast"),
             ("size: 512^3 volume + z stride 16", "integrate"), ("size: 128^3 volume", "integrate"),
             ("size: 128^3 volume + z stride 16", "integrate")]
    for name, stage in pairs:
        before = next((r.get("before") for r in f.res.runs_named() if r["name"] == name), None)
        lines.append(f.technique(name, stage, before or None) + ".")
    for seq in f.seqs:
        r, b = f.get("size: compute ratio 2", seq), f.get(f.base, seq)
        if r and b and r.get("config", {}).get("compute_size_ratio") == \
                b.get("config", {}).get("compute_size_ratio"):
            lines.append(f"On {seq} the compute ratio 2 rows use `{f.base}`'s own compute size "
                         "(this input is not the 320×240 .raw form), so they measure nothing "
                         "about size.")
    if not f.measured("size: compute ratio 2"):
        lines.append("Until these runs are measured, the explanation that a 320×240 raycast or a "
                     "256² integration grid fills less than one wave of the GPU (so fewer rays or "
                     "slices need not take less time) is a hypothesis, not a result.")
    return "\n".join(lines)


def reading_pareto(f, thesis):
    lines = ["**Reading.**"]
    for seq in f.seqs:
        b, t = f.get(f.base, seq), f.get("thesis", seq)
        if not b or not t:
            lines.append(f"{seq}: `thesis` or `{f.base}` {NOT_MEASURED}.")
            continue
        lo, hi = sorted((b["frames_per_second"], t["frames_per_second"]))
        inside = [r for r in f.res.ok if r["sequence"] == seq and lo <= r["frames_per_second"] <= hi
                  and ate_cm(r) is not None]
        held = [r for r in inside if not broken(r)]
        bad = [r for r in inside if broken(r)]
        text = (f"On {seq}, {len(inside)} configurations lie between `{f.base}` and `thesis` in "
                f"frames/s ({lo:.0f}–{hi:.0f}).")
        if held:
            a = [ate_cm(r) for r in held]
            text += (f" {len(held)} of them hold{'s' if len(held) == 1 else ''}, with ATE between {min(a):.2f} and {max(a):.2f} cm")
        text += ("; " if held else " ") + (
            f"{len(bad)} break{'s' if len(bad) == 1 else ''}: " + "; ".join(f"`{r['name']}` {state(r)}" for r in bad)
            if bad else "none breaks") + "."
        lines.append(text)
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# The thesis side by side.


def thesis_table(f, thesis, section):
    rows = [t for t in thesis["techniques"] if t["section"] == section]
    if not rows:
        return ""
    head = ("| technique | thesis (source) | thesis kernel | thesis frame | thesis ATE | kfx run | "
            + " | ".join(f"kfx kernel {short(s)}" for s in f.seqs) + " | "
            + " | ".join(f"kfx frame {short(s)}" for s in f.seqs) + " | "
            + " | ".join(f"kfx ATE {short(s)}" for s in f.seqs)
            + " | ray factor | why they differ |")
    out = [head, "|" + "---|" * (10 + 3 * (len(f.seqs) - 1) + 1)]
    expanded = []
    for t in rows:
        expanded.append(t)
        for alt in t.get("kfx_alternatives", []):
            expanded.append(dict(t, kfx_run=alt, title=t["title"] + " (kfx's other form)",
                                 kfx_alternatives=[]))
    for t in expanded:
        ks = t.get("stage_s")
        kernel = times(ks[0] / ks[1]) if ks else "–"
        if t.get("stages_s"):
            kernel = ", ".join(f"{st} {times(v[0] / v[1])}" for st, v in t["stages_s"].items())
        frame = times(t["frame_s"][0] / t["frame_s"][1]) if t.get("frame_s") else "–"
        ate = pct(100 * (t["ate"][1] / t["ate"][0] - 1)) if t.get("ate") else "–"
        if t.get("note") and not ks:
            kernel = frame = ate = "–"
        name = t["kfx_run"]
        stage = t.get("stage")
        cells, reasons = [], []
        recs = [f.get(name, s) for s in f.seqs]
        if not any(recs):
            cells = [NOT_MEASURED] + [""] * (3 * len(f.seqs) - 1)
            factor = "–"
        else:
            kk = [f.stage_speedup(name, s, stage) if stage else None for s in f.seqs]
            if t.get("stages_s"):
                kk_cells = [", ".join(f"{st} {times(f.stage_speedup(name, s, st))}"
                                      for st in t["stages_s"]) for s in f.seqs]
            else:
                kk_cells = [times(v) for v in kk]
            kf = [f.frame_speedup(name, s) for s in f.seqs]
            ka = []
            for r, s in zip(recs, f.seqs):
                b = ate_cm(f.get(f.base, s))
                if r is None or b is None or ate_cm(r) is None:
                    ka.append("–")
                else:
                    change = "breaks" if broken(r) else pct(100 * (ate_cm(r) / b - 1))
                    ka.append(f"{change} ({b:.2f} → {ate_cm(r):.2f} cm)")
            cells = kk_cells + [times(v) for v in kf] + ka
            factor = ", ".join(sorted({r.get("config", {}).get("ray_factor", "?")
                                       for r in recs if r}))
            reasons = why(f, t, name, stage, kk, kf, recs, thesis)
        out.append(f"| {t['title']} | {t['where']}" + (f"; {t['note']}" if t.get("note") else "")
                   + f" | {kernel} | {frame} | {ate} | `{name}` | " + " | ".join(cells)
                   + f" | {factor} | {'; '.join(reasons) or '–'} |")
    return "\n".join(out) + (
        "\n\nThesis: kernel and frame = ratio of its seconds before and after (its tables), ATE "
        "= change of its summed unaligned error. kfx: ratio of mean ms against `"
        + f.base + "`, ATE = change of the aligned RMSE; (breaks): ATE RMSE over 10 cm or more "
        "than 5 % of the frames beyond 10 cm. Stage compared: the one the thesis's row is about.")


def amdahl(share, kernel):
    """Frame speed-up when a stage that is `share` of the frame gets `kernel` times faster and
    nothing else changes."""
    return 1.0 / (1.0 - share * (1.0 - 1.0 / kernel)) if share is not None and kernel else None


def why(f, t, name, stage, kk, kf, recs, thesis):
    """Reasons where kfx and the thesis differ, each a condition on the numbers."""
    reasons = [t["kfx_note"]] if t.get("kfx_note") else []
    ks = t.get("stage_s")
    if t.get("thesis_before"):
        reasons.append(f"the thesis measured this on top of '{t['thesis_before']}', kfx against "
                       f"`{f.base}`")
    if ks and stage and not t.get("stages_s") and all(v is not None for v in kk):
        tk = ks[0] / ks[1]
        if max(kk) < 0.75 * tk:
            size = size_evidence(f, stage)
            reasons.append(f"the {stage} stage gains less than in the thesis"
                           + (f" ({size})" if size else ""))
        elif min(kk) > 1.33 * tk:
            reasons.append(f"the {stage} stage gains more than in the thesis")
    if t.get("frame_s") and stage and not t.get("stages_s") and all(v is not None for v in kf):
        tf = t["frame_s"][0] / t["frame_s"][1]
        if max(abs(v - tf) for v in kf) > 0.1 * (tf - 1.0) + 0.02:
            t_share = ks[0] / t["frame_s"][0]
            parts = []
            for s, k, v in zip(f.seqs, kk, kf):
                b = f.get(f.base, s)
                share = stage_ms(b, stage) / computation_ms(b)
                pred = amdahl(share, k)
                text = (f"{short(s)}: {stage} is {100 * share:.0f} % of the frame and gains "
                        f"{times(k)}, which alone gives {times(pred)}")
                if pred and v < pred - 0.03:
                    text += f" against {times(v)} measured ({f.stage_changes(name, s)})"
                parts.append(text)
            reasons.append("frame gain = stage share × stage gain: in the thesis " + stage
                           + f" is {100 * t_share:.0f} % of the frame and gains {times(ks[0] / ks[1])}"
                           + f" ({times(amdahl(t_share, ks[0] / ks[1]))}); " + "; ".join(parts))
    bad = [short(s) for r, s in zip(recs, f.seqs) if r and broken(r)]
    if bad:
        reasons.append("breaks " + ", ".join(bad) + " (other sequences than the thesis's "
                       "living room; the thesis's own code tracked no frame on ours, "
                       "../shared/reference/README.md)")
    return reasons


def size_evidence(f, stage):
    """What the size group measured about the stage: the exact stage time at another size."""
    if stage == "raycast":
        other, label = "size: compute ratio 2", "at compute ratio 2 (160×120 from .raw input)"
    elif stage == "integrate":
        other, label = "size: 128^3 volume", "with a 128³ volume"
    else:
        return ""
    if not f.measured(other):
        return "the size group that would test whether it fits one wave of the GPU is " + NOT_MEASURED
    parts = [f"{short(s)} {ms(stage_ms(f.get(other, s), stage))} against "
             f"{ms(stage_ms(f.get(f.base, s), stage))}" for s in f.seqs]
    return f"exact's {stage} {label}: " + ", ".join(parts)


def extra_values(res, figures):
    try:
        with open(THESIS_TABLES) as fh:
            thesis = json.load(fh)
    except (OSError, ValueError) as e:
        raise ToolError(f"{THESIS_TABLES}: cannot read the thesis's tables ({e}); set "
                        "KFX_THESIS_TABLES to docs/thesis-study/thesis_tables.json of a checkout")
    f = Facts(res)
    values = {
        "reading:presets": reading_presets(f, thesis),
        "reading:bilateral": reading_bilateral(f, thesis),
        "reading:tracking": reading_tracking(f, thesis),
        "reading:integrate": reading_integrate(f, thesis),
        "reading:raycast": reading_raycast(f, thesis),
        "reading:combining": reading_combining(f, thesis),
        "reading:size": reading_size(f, thesis),
        "reading:pareto": reading_pareto(f, thesis),
    }
    for section in ("presets", "bilateral", "tracking", "integrate", "raycast", "combining"):
        values[f"thesis_table:{section}"] = thesis_table(f, thesis, section)
    values["thesis_source"] = thesis["source"]
    return values
