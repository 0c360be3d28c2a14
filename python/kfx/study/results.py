"""Results of `kfx sweep` (docs/sweep.md): loading results.json, results.jsonl or results.csv,
the runs of one backend indexed by configuration and sequence, and the measures read off a run
(ATE, per-stage times, speed-ups, the Pareto front, a step sweep's series).

    from kfx.study import results
    res = results.Results(results.load_results("out/study"), backend="cpu")
    for name in res.names:
        print(name, [results.ate_cm(res.get(name, seq)) for seq in res.sequences])

Pure standard library. A file that cannot be read raises kfx.study.ToolError naming it.
"""

import csv
import json
import math
import os
import re
import sys

from . import ToolError

STAGES = ["preprocess", "track", "integrate", "raycast"]


def fail(message):
    raise ToolError(message)


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
                        print(f"kfx.study.results: skipping malformed line {number} of {path}",
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


def as_number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


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
