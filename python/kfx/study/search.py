"""The search mode of `kfx sweep` (docs/sweep.md, "Search"): Optuna proposes configurations.

A search plan is a sweep plan (same sequences, variants, data_root, settings, repeat, warm-up)
with a "search" section instead of hand-written runs: the knob space (names from `kfx settings`),
the objective (frames/s, aggregated over the sequences), the constraint (ATE at most ratio x the
baseline's on every sequence, and no more lost frames than the baseline), the number of trials,
the sampler and the held-out sequences. Every configuration is measured by `kfx sweep` itself
(one sweep call per batch of trials, frames held in memory, warm-up then timed passes as in
`kfx bench`); its results log doubles as a cache, so the baseline runs once per sequence.

The study lives in Optuna storage (default sqlite:///OUT/study.db): running the same command
again continues the same study. Outputs in OUT: trials.csv, trials.json, best.json (rewritten
after every trial), validation.json (best on the held-out sequences, and a leave-one-out
reading), and with --robustness: robustness.json / robustness.md.

Usage: scripts/kfx_search PLAN.json --out DIR [--kfx BIN] [--backend cpu|cuda|auto]
       [--trials N] [--max-minutes M] [--storage URL] [--study-name NAME] [--sampler NAME]
       [--seed S] [--batch N] [--variant V] [--data-root DIR] [--frames N] [--repeat N]
       [--warmup N] [--leave-out SEQ] [--robustness] [--top K] [--start-frames N,N]
       [--no-search]
       (or python -m kfx.study.search ... where the package is installed)
Optuna is imported when the search starts (Debian: python3-optuna; PyPI: optuna).
"""

import argparse
import csv
import hashlib
import io
import json
import math
import os
import shutil
import socket
import subprocess
import sys
import time

from . import ToolError, default_path, run_tool


def fail(message):
    """A clear error: the command line prints it and exits non-zero (status 1)."""
    raise ToolError(message)


def import_optuna():
    try:
        import optuna
    except ImportError:
        fail("optuna is not importable by " + sys.executable + " (Debian: python3-optuna, "
             "scripts/setup installs it; PyPI: optuna; GPU machine: scripts/search_wheels)")
    import warnings
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    return optuna


# ------------------------------------------------------------------------------------------------
# The plan


SEARCH_FIELDS = {"baseline", "preset", "knobs", "objective", "constraint", "trials", "sampler",
                 "held_out", "enqueue", "batch", "start_frames", "top"}
OBJECTIVE_METRICS = {"end_to_end_frames_per_second", "frames_per_second"}
AGGREGATES = {"geomean", "min", "mean", "total"}


def format_value(value):
    """A knob value as `kfx --set` text: 4 not 4.0, on/off for booleans."""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, float):
        if value == int(value) and abs(value) < 1e9:
            return str(int(value))
        return repr(round(value, 9))
    return str(value)


class Knob:
    """One searchable setting: a list of choices, or an int or float range with a step."""

    def __init__(self, name, spec, where):
        self.name = name
        if not isinstance(spec, dict):
            fail(f"{where}: knob '{name}' must be an object with choices, int or float")
        unknown = set(spec) - {"choices", "int", "float", "step", "log", "comment"}
        if unknown:
            fail(f"{where}: knob '{name}': unknown field(s) {sorted(unknown)}")
        kinds = [k for k in ("choices", "int", "float") if k in spec]
        if len(kinds) != 1:
            fail(f"{where}: knob '{name}' needs exactly one of choices, int, float")
        self.kind = kinds[0]
        self.log = bool(spec.get("log", False))
        if self.kind == "choices":
            self.choices = list(spec["choices"])
            if len(self.choices) < 1 or any(isinstance(c, (list, dict)) or c is None
                                            for c in self.choices):
                fail(f"{where}: knob '{name}': choices must be a non-empty list of strings, "
                     "numbers or booleans (write lists as \"2,2\")")
            self.step = None
        else:
            bounds = spec[self.kind]
            if not (isinstance(bounds, list) and len(bounds) == 2 and bounds[0] < bounds[1]):
                fail(f"{where}: knob '{name}': {self.kind} must be [low, high] with low < high")
            self.low, self.high = bounds
            if self.kind == "int":
                self.low, self.high = int(self.low), int(self.high)
                self.step = int(spec.get("step", 1))
            else:
                self.step = spec.get("step")
            if self.step is not None and self.step <= 0:
                fail(f"{where}: knob '{name}': step must be > 0")

    def describe(self):
        if self.kind == "choices":
            return {"choices": self.choices}
        return {self.kind: [self.low, self.high], "step": self.step, "log": self.log}

    def suggest(self, trial):
        if self.kind == "choices":
            return trial.suggest_categorical(self.name, self.choices)
        if self.kind == "int":
            return trial.suggest_int(self.name, self.low, self.high, step=self.step, log=self.log)
        if self.step is not None:
            return trial.suggest_float(self.name, self.low, self.high, step=self.step)
        return trial.suggest_float(self.name, self.low, self.high, log=self.log)

    def neighbours(self, value):
        """The values one step below and above `value` within the space (none past an end)."""
        if self.kind == "choices":
            index = [format_value(c) for c in self.choices].index(format_value(value))
            return [self.choices[i] for i in (index - 1, index + 1) if 0 <= i < len(self.choices)]
        step = self.step if self.step is not None else (self.high - self.low) / 10.0
        out = []
        for v in (value - step, value + step):
            if self.low - 1e-12 <= v <= self.high + 1e-12:
                out.append(int(v) if self.kind == "int" else round(v, 9))
        return out


class SearchPlan:
    """A sweep plan with a "search" section (docs/sweep.md)."""

    def __init__(self, path):
        self.path = os.path.abspath(path)
        try:
            with open(path) as f:
                self.raw = json.load(f)
        except OSError as e:
            fail(f"{path}: cannot read: {e.strerror}")
        except json.JSONDecodeError as e:
            fail(f"{path}:{e.lineno}:{e.colno}: malformed JSON: {e.msg}")
        if not isinstance(self.raw, dict) or not isinstance(self.raw.get("search"), dict):
            fail(f"{path}: not a search plan (needs a \"search\" object; docs/sweep.md)")
        if "runs" in self.raw:
            fail(f"{path}: a search plan has no \"runs\": the search proposes them")
        search = self.raw["search"]
        unknown = {k for k in search if not k.startswith("_") and k != "comment"} - SEARCH_FIELDS
        if unknown:
            fail(f"{path}: search: unknown field(s) {sorted(unknown)}; known: "
                 f"{sorted(SEARCH_FIELDS)}")
        self.name = self.raw.get("name") or os.path.splitext(os.path.basename(path))[0]
        self.sequences = [s.get("name") for s in self.raw.get("sequences", [])]
        if not self.sequences or not all(self.sequences):
            fail(f"{path}: sequences: a search plan needs named sequences")
        self.baseline_preset = search.get("baseline", "exact")
        self.preset = search.get("preset", self.raw.get("preset", "exact"))
        knobs = search.get("knobs")
        if not isinstance(knobs, dict) or not knobs:
            fail(f"{path}: search.knobs must be a non-empty object")
        self.knobs = [Knob(name, spec, f"{path}: search.knobs") for name, spec in knobs.items()]
        objective = search.get("objective", {})
        self.metric = objective.get("metric", "end_to_end_frames_per_second")
        self.aggregate = objective.get("aggregate", "geomean")
        if self.metric not in OBJECTIVE_METRICS:
            fail(f"{path}: search.objective.metric must be one of {sorted(OBJECTIVE_METRICS)}")
        if self.aggregate not in AGGREGATES:
            fail(f"{path}: search.objective.aggregate must be one of {sorted(AGGREGATES)}")
        constraint = search.get("constraint", {})
        self.ate_ratio = float(constraint.get("ate_ratio", 1.1))
        self.lost_slack = int(constraint.get("extra_lost_frames", 0))
        self.trials = int(search.get("trials", 100))
        sampler = search.get("sampler", {})
        if isinstance(sampler, str):
            sampler = {"name": sampler}
        self.sampler = sampler.get("name", "tpe")
        self.seed = int(sampler.get("seed", 1))
        self.startup_trials = int(sampler.get("startup_trials", 10))
        self.held_out = list(search.get("held_out", []))
        for name in self.held_out:
            if name not in self.sequences:
                fail(f"{path}: search.held_out: '{name}' is not a sequence of the plan")
        self.enqueue = list(search.get("enqueue", []))
        for point in self.enqueue:
            for key in point:
                if key not in knobs:
                    fail(f"{path}: search.enqueue: '{key}' is not a knob of the search")
        self.batch = int(search.get("batch", 1))
        self.start_frames = list(search.get("start_frames", []))
        self.top = int(search.get("top", 2))

    def search_sequences(self, leave_out=None):
        return [s for s in self.sequences if s not in self.held_out and s != leave_out]

    def space_digest(self):
        """What a resumed study must agree on: knobs, objective, constraint, baseline."""
        text = json.dumps({"knobs": [[k.name, k.describe()] for k in self.knobs],
                           "preset": self.preset, "baseline": self.baseline_preset,
                           "metric": self.metric, "aggregate": self.aggregate,
                           "ate_ratio": self.ate_ratio, "lost": self.lost_slack},
                          sort_keys=True)
        return hashlib.sha1(text.encode()).hexdigest()[:12]


# ------------------------------------------------------------------------------------------------
# Measuring configurations with `kfx sweep`


class Evaluator:
    """Runs named configurations on sequences through `kfx sweep`, results cached in its log."""

    def __init__(self, plan, args, out_dir):
        self.plan = plan
        self.args = args
        self.dir = os.path.join(out_dir, "runs")
        os.makedirs(self.dir, exist_ok=True)
        self.sweep_plan_path = os.path.join(out_dir, "sweep_plan.json")
        self.backend = args.backend

    def _base_plan(self):
        plan = {k: v for k, v in self.plan.raw.items() if k != "search"}
        plan["name"] = self.plan.name
        root = plan.get("data_root")
        if root and not os.path.isabs(root):
            plan["data_root"] = os.path.normpath(
                os.path.join(os.path.dirname(self.plan.path), root))
        plan["baseline"] = "baseline"
        return plan

    def run(self, configs, sequences, inputs=None):
        """Measures {run name: (preset, {key: value})} on `sequences`; returns
        {run name: {sequence: record}} and the sweep's error text ("" when it succeeded).
        `inputs` maps a sequence name to a replacement input (shifted copies)."""
        plan = self._base_plan()
        runs = [{"name": "baseline", "preset": self.plan.baseline_preset, "baseline": True}]
        for name, (preset, settings) in configs.items():
            if name == "baseline":
                continue
            runs.append({"name": name, "preset": preset,
                         "settings": {k: format_value(v) for k, v in settings.items()}})
        plan["runs"] = runs
        # Shifted copies are new sequences with the settings (and variants) of their source.
        by_name = {s["name"]: s for s in plan["sequences"]}
        for name, (_, source) in (inputs or {}).items():
            if name not in by_name:
                plan["sequences"].append(dict(by_name[source], name=name))
        tmp = self.sweep_plan_path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(plan, f, indent=1)
        os.replace(tmp, self.sweep_plan_path)
        sequence_args = []
        for s in sequences:
            if inputs and s in inputs:
                sequence_args.append(f"{s}={inputs[s][0]}")
            else:
                sequence_args.append(s)
        command = [self.args.kfx, "sweep", self.sweep_plan_path, "--out", self.dir,
                   "--backend", self.backend, "--only", ",".join(configs),
                   "--sequences", ",".join(sequence_args)]
        if self.args.variant:
            command += ["--variant", self.args.variant]
        for option in ("data_root", "frames", "repeat", "warmup"):
            value = getattr(self.args, option)
            if value is not None:
                command += ["--" + option.replace("_", "-"), str(value)]
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        error = ""
        if result.returncode != 0:
            lines = [l for l in result.stderr.splitlines() if "error" in l] or \
                result.stderr.splitlines()[-3:]
            error = " | ".join(lines)[-800:] or f"kfx sweep exited {result.returncode}"
        records = latest_records(os.path.join(self.dir, "results.jsonl"))
        out = {}
        for name in configs:
            out[name] = {}
            for s in sequences:
                record = records.get((name, s, self.backend))
                if record is not None and self._matches(record, *configs[name]):
                    out[name][s] = record
        return out, error


    def _matches(self, record, preset, settings):
        """Whether a log record answers this configuration (a reused name such as "best", or a
        sweep cut off before it ran, may leave an older record under the name)."""
        assignments = record.get("assignments", [])
        wanted = [f"{k}={format_value(v)}" for k, v in settings.items()]
        return (record.get("preset") == preset
                and record.get("max_frames") == (self.args.frames or 0)
                and all(a in assignments for a in wanted))


def latest_records(path):
    """{(name, sequence, backend): latest record} of a sweep's results.jsonl."""
    out = {}
    if not os.path.exists(path):
        return out
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue  # a cut-off last line; the sweep drops it itself next time
            out[(record.get("name"), record.get("sequence"), record.get("backend"))] = record
    return out


def summarise(record):
    """The figures the search uses from one sweep record."""
    if record is None:
        return {"status": "missing"}
    out = {"status": record.get("status", "missing")}
    if out["status"] != "ok":
        out["error"] = record.get("error", "")
        return out
    for key in ("frames", "tracked", "ate_rmse_m", "frames_per_second",
                "end_to_end_frames_per_second"):
        if key in record:
            out[key] = record[key]
    return out


# ------------------------------------------------------------------------------------------------
# Objective and constraint


def aggregate(plan, results, sequences):
    values = [results[s].get(plan.metric, 0.0) for s in sequences]
    if not values or any(v <= 0 for v in values):
        return 0.0
    if plan.aggregate == "geomean":
        return math.exp(sum(math.log(v) for v in values) / len(values))
    if plan.aggregate == "min":
        return min(values)
    if plan.aggregate == "mean":
        return sum(values) / len(values)
    frames = [results[s].get("frames", 0) for s in sequences]
    return sum(frames) / sum(f / v for f, v in zip(frames, values))


def check(plan, results, baseline, sequences):
    """Per-sequence constraint values (<= 0 holds, Optuna's convention) and the reasons that
    fail: ATE ratio minus the limit, then extra lost frames minus the allowed slack."""
    values, reasons = [], []
    for s in sequences:
        r, b = results.get(s, {}), baseline[s]
        if r.get("status") != "ok":
            values += [1e3, 1e3]
            reasons.append(f"{s}: {r.get('status', 'missing')} {r.get('error', '')}".strip())
            continue
        if "ate_rmse_m" in r and b.get("ate_rmse_m"):
            ratio = r["ate_rmse_m"] / b["ate_rmse_m"]
            values.append(ratio - plan.ate_ratio)
            if ratio > plan.ate_ratio:
                reasons.append(f"{s} ATE {ratio:.2f}x")
        else:
            values.append(0.0)
        lost = (r["frames"] - r["tracked"]) - (b["frames"] - b["tracked"])
        values.append(float(lost - plan.lost_slack))
        if lost > plan.lost_slack:
            reasons.append(f"{s} {lost} more lost")
    return values, reasons


def worst_ratio(results, baseline, sequences):
    ratios = [results[s]["ate_rmse_m"] / baseline[s]["ate_rmse_m"] for s in sequences
              if results.get(s, {}).get("status") == "ok" and "ate_rmse_m" in results[s]
              and baseline[s].get("ate_rmse_m")]
    return max(ratios) if ratios else None


def constraints_func(frozen_trial):
    return frozen_trial.user_attrs.get("constraints", [1e3])


# ------------------------------------------------------------------------------------------------
# Study


def trial_constraints_api(optuna):
    """Optuna >= 5 takes constraints from Trial.set_constraint (constraints_func is deprecated
    there); older ones from the sampler's constraints_func."""
    return hasattr(optuna.trial.Trial, "set_constraint")


def make_sampler(optuna, name, seed, startup):
    """The sampler and whether it takes the constraint into account."""
    constrained = {} if trial_constraints_api(optuna) else {"constraints_func": constraints_func}
    if name == "tpe":
        try:
            return optuna.samplers.TPESampler(seed=seed, n_startup_trials=startup,
                                              multivariate=True, **constrained), True
        except TypeError:  # an Optuna without constrained TPE: the objective is penalised
            return optuna.samplers.TPESampler(seed=seed, n_startup_trials=startup), False
    if name == "random":
        return optuna.samplers.RandomSampler(seed=seed), False
    if name == "nsga2":  # evolutionary
        return optuna.samplers.NSGAIISampler(seed=seed, population_size=max(8, startup),
                                             **constrained), True
    if name == "gp":  # Gaussian-process surrogate (Optuna >= 3.6, needs torch and scipy)
        if not hasattr(optuna.samplers, "GPSampler"):
            fail(f"sampler 'gp' needs Optuna >= 3.6 (this is {optuna.__version__})")
        try:
            return optuna.samplers.GPSampler(seed=seed, n_startup_trials=startup,
                                             **constrained), True
        except TypeError:
            fail(f"sampler 'gp' with constraints needs a newer Optuna than {optuna.__version__}")
    fail(f"unknown sampler '{name}' (tpe, random, nsga2, gp)")


def pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def recover_stale(optuna, study):
    """Trials left RUNNING by an interrupted run of this machine fail, and their configuration
    is queued again so the interruption loses nothing."""
    host = socket.gethostname()
    for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
        worker = t.user_attrs.get("worker", "")
        if not worker.startswith(host + ":"):
            continue
        if pid_alive(int(worker.split(":")[1])) and int(worker.split(":")[1]) != os.getpid():
            continue
        study.tell(t.number, state=optuna.trial.TrialState.FAIL)
        if t.params:
            study.enqueue_trial(t.params)
        print(f"kfx_search: trial {t.number} was interrupted; its configuration is queued again",
              file=sys.stderr)


def finished(optuna, study):
    return [t for t in study.get_trials(deepcopy=False)
            if t.state == optuna.trial.TrialState.COMPLETE]


def trial_row(t):
    attrs = t.user_attrs
    return {"number": t.number, "value": t.value, "feasible": attrs.get("feasible", False),
            "reasons": attrs.get("reasons", []), "settings": attrs.get("settings", t.params),
            "results": attrs.get("results", {}), "duration_s": attrs.get("duration_s")}


def best_row(rows):
    feasible = [r for r in rows if r["feasible"] and r["value"]]
    return max(feasible, key=lambda r: r["value"]) if feasible else None


def write_atomic(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def write_outputs(out_dir, plan, rows, baseline, sequences, meta):
    """trials.json, trials.csv and best.json, rewritten whole after every trial."""
    write_atomic(os.path.join(out_dir, "trials.json"),
                 json.dumps({**meta, "baseline": baseline, "trials": rows}, indent=1) + "\n")
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    knob_names = [k.name for k in plan.knobs]
    header = ["number", "value", "feasible", "reasons"] + knob_names
    for s in sequences:
        header += [f"{s}_fps", f"{s}_e2e_fps", f"{s}_ate_m", f"{s}_tracked", f"{s}_frames"]
    writer.writerow(header)
    for r in rows:
        line = [r["number"], r["value"], r["feasible"], "; ".join(r["reasons"])]
        line += [format_value(r["settings"].get(k, "")) for k in knob_names]
        for s in sequences:
            x = r["results"].get(s, {})
            line += [x.get("frames_per_second", ""), x.get("end_to_end_frames_per_second", ""),
                     x.get("ate_rmse_m", ""), x.get("tracked", ""), x.get("frames", "")]
        writer.writerow(line)
    write_atomic(os.path.join(out_dir, "trials.csv"), buffer.getvalue())
    best = best_row(rows)
    if best is not None:
        settings = {k: format_value(v) for k, v in best["settings"].items()}
        document = {**meta, "trial": best["number"], "value": best["value"],
                    "preset": plan.preset, "settings": settings,
                    "set_arguments": " ".join(f"--set {k}={v}" for k, v in settings.items()),
                    "results": best["results"], "baseline": baseline,
                    "worst_ate_ratio": worst_ratio(best["results"], baseline, sequences)}
        write_atomic(os.path.join(out_dir, "best.json"), json.dumps(document, indent=1) + "\n")


def duration(seconds):
    s = int(seconds + 0.5)
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


def measure_baseline(evaluator, plan, study, sequences):
    """The baseline preset on every sequence, kept in the study's user attributes."""
    stored = study.user_attrs.get("baseline", {})
    missing = [s for s in sequences if stored.get(s, {}).get("status") != "ok"]
    if missing:
        print(f"kfx_search: measuring the baseline ({plan.baseline_preset}) on "
              f"{', '.join(missing)}", file=sys.stderr)
        results, error = evaluator.run({"baseline": (plan.baseline_preset, {})}, missing)
        for s in missing:
            stored[s] = summarise(results["baseline"].get(s))
            if stored[s]["status"] != "ok":
                fail(f"the baseline failed on {s}: {stored[s].get('error') or error}")
        study.set_user_attr("baseline", stored)
    for s in sequences:
        b = stored[s]
        ate = f", ATE {b['ate_rmse_m'] * 100:.2f} cm" if "ate_rmse_m" in b else ", no ATE"
        print(f"kfx_search: baseline on {s}: {b[plan.metric]:.0f} frames/s, "
              f"{b['tracked']}/{b['frames']} tracked{ate}", file=sys.stderr)
    return stored


def run_search(optuna, plan, args, out_dir, evaluator, study, sequences, baseline, constrained):
    target = args.trials if args.trials is not None else plan.trials
    batch = args.batch if args.batch is not None else plan.batch
    constraint_names = [f"{s}_{kind}" for s in sequences for kind in ("ate", "lost")]
    recover_stale(optuna, study)
    # The plan's starting points, each queued once per study (also when added to the plan later).
    tried = [{k: format_value(v) for k, v in t.params.items()} for t in study.get_trials(
        deepcopy=False)] + [{k: format_value(v) for k, v in t.system_attrs.get(
            "fixed_params", {}).items()} for t in study.get_trials(deepcopy=False)]
    for point in plan.enqueue:
        if {k: format_value(v) for k, v in point.items()} not in tried:
            study.enqueue_trial(point)
    start = args.start_time
    durations = []
    meta = {"plan": plan.name, "study": study.study_name, "sequences": sequences,
            "objective": f"{plan.aggregate} of {plan.metric}",
            "constraint": f"ATE <= {plan.ate_ratio} x {plan.baseline_preset}'s and lost frames "
                          f"<= {plan.baseline_preset}'s + {plan.lost_slack} on every sequence",
            "trials_target": target, "backend": args.backend}
    while True:
        done = len(finished(optuna, study))
        if done >= target:
            break
        if args.max_minutes and durations:
            per_trial = sum(durations) / len(durations)
            if time.time() - start + per_trial > 60 * args.max_minutes:
                print(f"kfx_search: stopping: --max-minutes {args.max_minutes} would be passed "
                      f"({done}/{target} trials done; the same command continues)",
                      file=sys.stderr)
                break
        trials = []
        for _ in range(min(batch, target - done)):
            trial = study.ask()
            trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
            settings = {k.name: k.suggest(trial) for k in plan.knobs}
            trials.append((trial, settings))
        t0 = time.time()
        configs = {f"t{t.number:05d}": (plan.preset, s) for t, s in trials}
        results, error = evaluator.run(configs, sequences)
        elapsed = (time.time() - t0) / len(trials)
        for trial, settings in trials:
            per_sequence = {s: summarise(results[f"t{trial.number:05d}"].get(s))
                            for s in sequences}
            if error and all(r["status"] == "missing" for r in per_sequence.values()):
                for r in per_sequence.values():
                    r["error"] = error
            constraint_values, reasons = check(plan, per_sequence, baseline, sequences)
            feasible = all(v <= 0 for v in constraint_values)
            value = aggregate(plan, per_sequence, sequences)
            trial.set_user_attr("settings", settings)
            trial.set_user_attr("results", per_sequence)
            trial.set_user_attr("constraints", constraint_values)
            if trial_constraints_api(optuna):
                for name, v in zip(constraint_names, constraint_values):
                    trial.set_constraint(name, v)
            trial.set_user_attr("feasible", feasible)
            trial.set_user_attr("reasons", reasons)
            trial.set_user_attr("duration_s", elapsed)
            # Without constraint support in the sampler, an infeasible trial scores 0.
            study.tell(trial, value if (feasible or constrained) else 0.0)
            durations.append(elapsed)
            rows = [trial_row(t) for t in finished(optuna, study)]
            write_outputs(out_dir, plan, rows, baseline, sequences, meta)
            best = best_row(rows)
            n = len(rows)
            left = max(0, target - n)
            eta = sum(durations) / len(durations) * left
            if args.max_minutes:
                eta = min(eta, max(0.0, 60 * args.max_minutes - (time.time() - start)))
            state = "feasible" if feasible else "infeasible: " + ", ".join(reasons)
            best_text = (f"best {best['value']:.0f} frames/s (trial {best['number']})"
                         if best else "no feasible trial yet")
            print(f"[{n}/{target}] trial {trial.number}: {value:.0f} frames/s, {state}; "
                  f"{best_text} ({duration(time.time() - start)} elapsed, "
                  f"ETA {duration(eta)})", file=sys.stderr, flush=True)
    rows = [trial_row(t) for t in finished(optuna, study)]
    write_outputs(out_dir, plan, rows, baseline, sequences, meta)
    return rows


# ------------------------------------------------------------------------------------------------
# Validation: held-out sequences and leave-one-out


def validate(plan, evaluator, best, baseline_all, search_sequences, held_out, rows):
    """The best configuration on the held-out sequences, and a post-hoc leave-one-out reading:
    for each search sequence s, the best trial chosen without looking at s, checked on s (from
    the measurements already made; the sampler itself did see s)."""
    report = {"best_trial": best["number"] if best else None, "held_out": {},
              "leave_one_out": {}}
    if best and held_out:
        results, error = evaluator.run({"best": (plan.preset, best["settings"])}, held_out)
        per_sequence = {s: summarise(results["best"].get(s)) for s in held_out}
        values, reasons = check(plan, per_sequence, baseline_all, held_out)
        report["held_out"] = {"results": per_sequence, "holds": all(v <= 0 for v in values),
                              "reasons": reasons, "error": error,
                              "worst_ate_ratio": worst_ratio(per_sequence, baseline_all,
                                                             held_out)}
    for s in search_sequences:
        others = [o for o in search_sequences if o != s]
        candidates = []
        for r in rows:
            values, _ = check(plan, r["results"], baseline_all, others)
            if others and all(v <= 0 for v in values):
                candidates.append((aggregate(plan, r["results"], others), r))
        if not candidates:
            report["leave_one_out"][s] = {"chosen": None}
            continue
        value, chosen = max(candidates, key=lambda c: c[0])
        values, reasons = check(plan, chosen["results"], baseline_all, [s])
        report["leave_one_out"][s] = {
            "chosen": chosen["number"], "value_without": value,
            "holds_on_left_out": all(v <= 0 for v in values), "reasons": reasons,
            "ate_ratio": worst_ratio(chosen["results"], baseline_all, [s])}
    return report


# ------------------------------------------------------------------------------------------------
# Robustness: neighbours in the knob space and other start frames


def shifted_copy(source, skip, work_dir, kfx):
    """A copy of `source` (SLAMBench .raw with its sidecar, TUM or ICL-NUIM PNG folder, or a
    synthetic:... input, converted first) without its first `skip` frames."""
    os.makedirs(work_dir, exist_ok=True)
    if source.startswith("synthetic"):
        raw = os.path.join(work_dir, hashlib.sha1(source.encode()).hexdigest()[:10] + ".raw")
        if not os.path.exists(raw):
            subprocess.run([kfx, "convert", source, raw, "--ratio", "1"], check=True,
                           stdout=subprocess.DEVNULL)
        source = raw
    base = os.path.basename(source.rstrip("/"))
    if source.endswith(".raw"):
        target = os.path.join(work_dir, f"{base[:-4]}_from{skip}.raw")
        if os.path.exists(target):
            return target
        with open(source, "rb") as f:
            header = f.read(8)
            w, h = int.from_bytes(header[:4], "little"), int.from_bytes(header[4:], "little")
        frame_bytes = 8 + 2 * w * h + 8 + 3 * w * h
        size = os.path.getsize(source)
        if size % frame_bytes or skip * frame_bytes >= size:
            raise RuntimeError(f"{source}: cannot skip {skip} frames ({size} bytes, "
                               f"{frame_bytes} per frame)")
        with open(source, "rb") as f, open(target + ".tmp", "wb") as g:
            f.seek(skip * frame_bytes)
            shutil.copyfileobj(f, g, 1 << 24)
        if os.path.exists(source + ".json"):
            with open(source + ".json") as f:
                sidecar = json.load(f)
            if "stamps" in sidecar:
                sidecar["stamps"] = sidecar["stamps"][skip:]
            else:  # stamps default to frame index + 1
                sidecar["stamps"] = [float(i + 1) for i in range(skip, size // frame_bytes)]
            with open(target + ".json", "w") as f:
                json.dump(sidecar, f)
        os.replace(target + ".tmp", target)
        return target
    if os.path.isdir(source):
        listing = next((n for n in ("associations.txt", "depth.txt")
                        if os.path.exists(os.path.join(source, n))), None)
        if listing is None:
            raise RuntimeError(f"{source}: no associations.txt or depth.txt to shift")
        target = os.path.join(work_dir, f"{base}_from{skip}")
        if os.path.exists(target):
            return target
        os.makedirs(target + ".tmp")
        for entry in os.listdir(source):
            if entry != listing:
                os.symlink(os.path.join(os.path.abspath(source), entry),
                           os.path.join(target + ".tmp", entry))
        kept, dropped = [], 0
        with open(os.path.join(source, listing)) as f:
            for line in f:
                if line.startswith("#") or not line.strip() or dropped >= skip:
                    kept.append(line)
                else:
                    dropped += 1
        with open(os.path.join(target + ".tmp", listing), "w") as f:
            f.writelines(kept)
        os.replace(target + ".tmp", target)
        return target
    raise RuntimeError(f"{source}: cannot make a shifted copy of this input")


def resolved_input(plan, args, name):
    """A sequence's input as `kfx sweep` resolves it (variant, data root)."""
    sequence = next(s for s in plan.raw["sequences"] if s["name"] == name)
    source = sequence.get("input", "")
    if args.variant:
        source = sequence.get("variants", {}).get(args.variant, {}).get("input", source)
    if source.startswith("synthetic") or os.path.isabs(source):
        return source
    root = args.data_root or os.path.join(os.path.dirname(plan.path),
                                          plan.raw.get("data_root", "."))
    return os.path.normpath(os.path.join(root, source))


def write_robustness(out_dir, plan, report, sequences, starts):
    """robustness.json and robustness.md of the candidates checked so far."""
    # Preferred: the most neighbours and start frames holding, then the larger margin, then
    # the faster (robustness beats the last few per cent).
    def robust_key(c):
        held = sum(n["holds"] for n in c["neighbours"]) + c["start_frames"].get("holds", True)
        return (held, c["margin"] if c["margin"] is not None else -1e9, c["value"])
    report["preferred"] = (max(report["candidates"], key=robust_key)["trial"]
                           if report["candidates"] else None)
    write_atomic(os.path.join(out_dir, "robustness.json"), json.dumps(report, indent=1) + "\n")
    lines = ["# Robustness of the best feasible configurations", "",
             f"Sequences: {', '.join(sequences)}; start frames: {starts or 'none'}; "
             f"limit: ATE <= {plan.ate_ratio} x {plan.baseline_preset}'s.", "",
             "| configuration | holds | objective | worst ATE ratio | why not |",
             "|---|---|---|---|---|"]
    for c in report["candidates"]:
        for n in c["neighbours"]:
            if n["name"] == f"t{c['trial']:05d}":
                n = dict(n, name=f"t{c['trial']:05d} itself (measured again)")
            ratio = f"{n['worst_ate_ratio']:.3f}" if n["worst_ate_ratio"] else "-"
            lines.append(f"| {n['name']} | {'yes' if n['holds'] else 'no'} | {n['value']:.0f} | "
                         f"{ratio} | {'; '.join(n['reasons'])} |")
        if c["start_frames"]:
            sf = c["start_frames"]
            ratio = f"{sf['worst_ate_ratio']:.3f}" if sf["worst_ate_ratio"] else "-"
            lines.append(f"| t{c['trial']:05d} other start frames | "
                         f"{'yes' if sf['holds'] else 'no'} | | {ratio} | "
                         f"{'; '.join(sf['reasons'])} |")
    lines += ["", f"Preferred (most neighbours and start frames holding, then margin, then "
              f"speed): "
              f"{'trial ' + str(report['preferred']) if report['preferred'] is not None else 'none'}"]
    write_atomic(os.path.join(out_dir, "robustness.md"), "\n".join(lines) + "\n")


def robustness(plan, args, out_dir, evaluator, rows, baseline, sequences):
    """For the best feasible trials: every one-step neighbour in the knob space and each other
    start frame, with the margin (worst ATE ratio to the baseline) of each."""
    feasible = sorted((r for r in rows if r["feasible"] and r["value"]),
                      key=lambda r: -r["value"])
    top = args.top if args.top is not None else plan.top
    starts = args.start_frames if args.start_frames is not None else plan.start_frames
    knobs = {k.name: k for k in plan.knobs}
    report = {"sequences": sequences, "start_frames": starts, "candidates": []}
    inputs = {}
    if starts:
        for s in sequences:
            for skip in starts:
                try:
                    copy = shifted_copy(resolved_input(plan, args, s), skip,
                                        os.path.join(args.out, "shifted"),
                                        args.kfx)
                    inputs[f"{s}_from{skip}"] = (copy, s)
                except (RuntimeError, OSError, subprocess.CalledProcessError) as e:
                    report.setdefault("notes", []).append(f"{s} from frame {skip}: {e}")
        if inputs:
            names = list(inputs)
            results, error = evaluator.run({"baseline": (plan.baseline_preset, {})}, names,
                                           inputs)
            for name in names:
                baseline[name] = summarise(results["baseline"].get(name))
    for candidate in feasible[:top]:
        configs = {f"t{candidate['number']:05d}": (plan.preset, candidate["settings"])}
        for name, value in candidate["settings"].items():
            for v in knobs[name].neighbours(value):
                settings = dict(candidate["settings"], **{name: v})
                # No commas in run names: kfx sweep --only splits on them.
                label = format_value(v).replace(",", "-")
                configs[f"t{candidate['number']:05d}_{name}={label}"] = (plan.preset, settings)
        print(f"kfx_search: robustness of trial {candidate['number']}: {len(configs)} "
              f"configurations (itself and its neighbours) on {len(sequences)} sequences"
              + (f", then {len(inputs)} shifted copies" if inputs else ""), file=sys.stderr)
        results, error = evaluator.run(configs, sequences)
        entry = {"trial": candidate["number"], "value": candidate["value"],
                 "settings": candidate["settings"], "neighbours": [], "start_frames": {}}
        for name in configs:
            per_sequence = {s: summarise(results[name].get(s)) for s in sequences}
            values, reasons = check(plan, per_sequence, baseline, sequences)
            entry["neighbours"].append({
                "name": name, "holds": all(v <= 0 for v in values), "reasons": reasons,
                "value": aggregate(plan, per_sequence, sequences),
                "worst_ate_ratio": worst_ratio(per_sequence, baseline, sequences)})
        if inputs:
            own_name = f"t{candidate['number']:05d}"
            shifted, error = evaluator.run({own_name: configs[own_name]}, list(inputs), inputs)
            per_sequence = {s: summarise(shifted[own_name].get(s)) for s in inputs}
            ok = {s: r for s, r in per_sequence.items() if baseline.get(s, {}).get("status") == "ok"}
            values, reasons = check(plan, ok, baseline, list(ok))
            entry["start_frames"] = {"holds": all(v <= 0 for v in values), "reasons": reasons,
                                     "worst_ate_ratio": worst_ratio(ok, baseline, list(ok)),
                                     "results": per_sequence}
        ratios = [n["worst_ate_ratio"] for n in entry["neighbours"] if n["worst_ate_ratio"]]
        if entry["start_frames"].get("worst_ate_ratio"):
            ratios.append(entry["start_frames"]["worst_ate_ratio"])
        entry["worst_ate_ratio"] = max(ratios) if ratios else None
        entry["margin"] = plan.ate_ratio - entry["worst_ate_ratio"] if ratios else None
        entry["all_hold"] = all(n["holds"] for n in entry["neighbours"]) and \
            entry["start_frames"].get("holds", True)
        report["candidates"].append(entry)
        print(f"kfx_search: robustness of trial {candidate['number']}: "
              f"{sum(n['holds'] for n in entry['neighbours'])}/{len(entry['neighbours'])} "
              f"neighbours hold, worst ATE ratio {entry['worst_ate_ratio']}", file=sys.stderr)
        # Written after every candidate, so a run cut off by a time limit keeps what it did.
        write_robustness(out_dir, plan, report, sequences, starts)
    write_robustness(out_dir, plan, report, sequences, starts)
    return report


# ------------------------------------------------------------------------------------------------


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Search mode of kfx sweep: Optuna proposes configurations (docs/sweep.md)")
    parser.add_argument("plan", help="search plan (a sweep plan with a \"search\" section)")
    parser.add_argument("--out", required=True, help="output folder (study.db, trials.*, best.json)")
    parser.add_argument("--kfx", default=default_path("build", "release", "kfx"),
                        help="kfx binary (default: build/release/kfx)")
    parser.add_argument("--backend", default="auto", choices=["cpu", "cuda", "auto"])
    parser.add_argument("--trials", type=int, help="trials the study should have in all "
                        "(default: the plan's); a larger number continues a finished study")
    parser.add_argument("--max-minutes", type=float, default=0,
                        help="start no trial that would end after this many minutes")
    parser.add_argument("--storage", help="Optuna storage URL (default: sqlite:///OUT/study.db; "
                        "postgresql://... to share one study between machines)")
    parser.add_argument("--study-name", help="default: the plan's name (+ -without-SEQ)")
    parser.add_argument("--sampler", choices=["tpe", "random", "nsga2", "gp"],
                        help="default: the plan's, else tpe")
    parser.add_argument("--seed", type=int, help="sampler seed (default: the plan's, else 1)")
    parser.add_argument("--batch", type=int, help="trials measured per kfx sweep call")
    parser.add_argument("--variant", help="sequence variant (e.g. raw320), as for kfx sweep")
    parser.add_argument("--data-root", help="folder of relative inputs, as for kfx sweep")
    parser.add_argument("--frames", type=int, help="at most N frames per sequence")
    parser.add_argument("--repeat", type=int, help="timed passes per run")
    parser.add_argument("--warmup", type=int, help="warm-up frames per run")
    parser.add_argument("--leave-out", help="search without this sequence, then validate on it")
    parser.add_argument("--robustness", action="store_true",
                        help="after the search: neighbours and other start frames of the best")
    parser.add_argument("--top", type=int, help="how many best feasible trials --robustness checks")
    parser.add_argument("--start-frames", type=lambda t: [int(x) for x in t.split(",") if x],
                        help="other start frames for --robustness, e.g. 100,200")
    parser.add_argument("--no-search", action="store_true",
                        help="run no new trial (validation and robustness of the study so far)")
    args = parser.parse_args(argv)
    args.start_time = time.time()  # --max-minutes counts from here, baseline included
    if args.trials is not None and args.trials < 0:
        fail("--trials must be >= 0")

    plan = SearchPlan(args.plan)
    if args.leave_out and args.leave_out not in plan.search_sequences():
        fail(f"--leave-out '{args.leave_out}' is not a search sequence of {args.plan} "
             f"({', '.join(plan.search_sequences())})")
    args.kfx = os.path.abspath(args.kfx)
    if not os.access(args.kfx, os.X_OK):
        fail(f"kfx binary '{args.kfx}' not found (build it, or pass --kfx)")
    known = subprocess.run([args.kfx, "settings"], stdout=subprocess.PIPE, text=True).stdout
    keys = {line.split()[0] for line in known.splitlines() if line.startswith("  ")}
    for knob in plan.knobs:
        if knob.name not in keys:
            fail(f"{args.plan}: search.knobs: unknown setting '{knob.name}' (see kfx settings)")
    optuna = import_optuna()

    out_dir = args.out = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    storage = args.storage or f"sqlite:///{os.path.join(out_dir, 'study.db')}"
    study_name = args.study_name or plan.name + (f"-without-{args.leave_out}"
                                                 if args.leave_out else "")
    sampler, constrained = make_sampler(optuna, args.sampler or plan.sampler,
                           args.seed if args.seed is not None else plan.seed, plan.startup_trials)
    study = optuna.create_study(study_name=study_name, storage=storage, sampler=sampler,
                                direction="maximize", load_if_exists=True)
    digest = plan.space_digest()
    if study.user_attrs.get("space") not in (None, digest):
        fail(f"study '{study_name}' in {storage} was made with another knob space, objective or "
             "constraint; use another --study-name or --out")
    study.set_user_attr("space", digest)
    if args.backend == "auto":
        has_gpu = shutil.which("nvidia-smi") and subprocess.run(
            ["nvidia-smi", "-L"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        ).returncode == 0
        args.backend = "cuda" if has_gpu else "cpu"
    if study.user_attrs.get("backend") not in (None, args.backend):
        fail(f"study '{study_name}' was measured on {study.user_attrs['backend']}, "
             f"not {args.backend}")
    study.set_user_attr("backend", args.backend)
    measurement = {"frames": args.frames or 0, "variant": args.variant or ""}
    if study.user_attrs.get("measurement") not in (None, measurement):
        fail(f"study '{study_name}' was measured with {study.user_attrs['measurement']}, not "
             f"{measurement} (--frames, --variant); use another --study-name or --out")
    study.set_user_attr("measurement", measurement)

    evaluator = Evaluator(plan, args, out_dir)
    # A leave-one-out search writes its results beside the main study's, not over them.
    results_dir = os.path.join(out_dir, f"without-{args.leave_out}") if args.leave_out else out_dir
    os.makedirs(results_dir, exist_ok=True)
    sequences = plan.search_sequences(args.leave_out)
    held_out = plan.held_out + ([args.leave_out] if args.leave_out else [])
    baseline = measure_baseline(evaluator, plan, study, sequences + held_out)
    print(f"kfx_search: study '{study_name}' ({storage}), sampler {type(sampler).__name__}, "
          f"{len(finished(optuna, study))} trials done; searching on {', '.join(sequences)}"
          + (f"; held out: {', '.join(held_out)}" if held_out else ""), file=sys.stderr)
    if args.no_search:
        args.trials = 0
    rows = run_search(optuna, plan, args, results_dir, evaluator, study, sequences, baseline,
                      constrained)
    best = best_row(rows)
    report = validate(plan, evaluator, best, baseline, sequences, held_out, rows)
    write_atomic(os.path.join(results_dir, "validation.json"), json.dumps(report, indent=1) + "\n")
    if best:
        print(f"kfx_search: best: trial {best['number']}, {best['value']:.0f} frames/s: "
              + " ".join(f"{k}={format_value(v)}" for k, v in best["settings"].items()),
              file=sys.stderr)
        if report["held_out"]:
            h = report["held_out"]
            print(f"kfx_search: on the held-out sequences it "
                  f"{'holds' if h['holds'] else 'does NOT hold: ' + ', '.join(h['reasons'])}",
                  file=sys.stderr)
    else:
        print("kfx_search: no feasible trial yet", file=sys.stderr)
    if args.robustness:
        robustness(plan, args, results_dir, evaluator, rows, baseline, sequences)
    print(f"kfx_search: {len(rows)} trials; results in {results_dir}/"
          "{trials.csv,trials.json,best.json,validation.json}")
    return 0


if __name__ == "__main__":
    sys.exit(run_tool("kfx_search", main, status=1))
