"""kfx.study and kfx.plots, the tools above the library: sweep results read and aggregated (a
hand-made results set whose every figure is known, and a tiny real `kfx sweep` when the CLI is
built), the search plan's objective and constraint, the ATE breakdown's alignment, a figure
written when matplotlib is installed, and that `import kfx` pulls in neither matplotlib nor
Optuna."""

import json
import math
import os
import subprocess
import sys

import pytest

from conftest import ROOT, kfx_cli
from kfx.study import ToolError, ate_breakdown, energy, results, search, search_summary, tables


def record(name, sequence, ate_cm, ms, group=None, before="", step="", step_key="",
           settings=(), mark=False, status="ok", backend="cpu", frames=20, tracked=20,
           table=None):
    """One run as `kfx sweep` records it (the fields the tools read)."""
    r = {"name": name, "sequence": sequence, "group": group or name, "before": before,
         "step": step, "step_key": step_key, "settings": list(settings), "mark": mark,
         "status": status, "backend": backend, "frames": frames, "tracked": tracked,
         "table": bool(before) and not step if table is None else table,
         "preset": "exact", "device": "test CPU", "commit": "abc1234", "date": "2026-11-25",
         "repeat": 1}
    if status == "ok":
        stages = {"preprocess": 0.1, "track": ms * 0.5, "integrate": ms * 0.3,
                  "raycast": ms * 0.2 - 0.1}
        r.update({"ate_rmse_m": ate_cm / 100.0, "computation_ms": {"mean": ms},
                  "stages_ms": {k: {"mean": v} for k, v in stages.items()},
                  "frames_per_second": 1000.0 / ms, "diverged_frames": 0,
                  "config": {"icp_stride_px": "1"}})
    else:
        r["error"] = "kfx run exited 1"
    return r


RUNS = [
    record("exact", "room", 2.0, 10.0, mark=True),
    record("fast", "room", 2.2, 4.0, before="exact", mark=True),
    record("stride_2", "room", 2.1, 8.0, group="stride", before="exact", step="2",
           step_key="icp_stride_px", settings=["icp_stride_px=2"]),
    record("stride_4", "room", 3.0, 6.0, group="stride", before="exact", step="4",
           step_key="icp_stride_px", settings=["icp_stride_px=4"]),
    record("slow_and_bad", "room", 5.0, 20.0, before="exact"),
    record("broken", "room", 0, 0, status="failed"),
]


@pytest.fixture()
def results_json(tmp_path):
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"runs": RUNS}))
    return path


def test_results_are_indexed_and_measured(results_json):
    res = results.Results(results.load_results(str(results_json.parent)), None)
    assert res.backend == "cpu"
    assert res.sequences == ["room"]
    assert [r["name"] for r in res.failed] == ["broken"]
    assert len(res.ok) == 5
    fast = res.get("fast", "room")
    assert results.ate_cm(fast) == pytest.approx(2.2)
    assert results.computation_ms(fast) == 4.0
    assert results.stage_ms(fast, "track") == pytest.approx(2.0)
    assert results.speedup(res.get("exact", "room"), fast) == pytest.approx(2.5)
    assert results.most_changed_stage(res.get("exact", "room"), fast)[0] == "track"
    assert results.ate_cm(None) is None


def test_pareto_front_and_step_series(results_json):
    res = results.Results(results.load_results(str(results_json)), "cpu")
    # (frames/s, ATE cm): the front keeps what no other run beats on both.
    front = results.pareto_front([(100.0, 2.0), (250.0, 2.2), (125.0, 2.1), (50.0, 5.0),
                                  (166.7, 3.0)])
    assert sorted(front) == [(100.0, 2.0), (125.0, 2.1), (250.0, 2.2)]
    # A step sweep over the baseline's preset starts at the baseline's own value (1).
    series = results.step_series(res, "stride", "room")
    assert [step for step, _ in series] == ["1", "2", "4"]
    assert results.step_groups(res) == ["stride"]


def test_tables_hold_the_figures(results_json):
    res = results.Results(results.load_results(str(results_json)), "cpu")
    table = tables.before_after_table(res, "fast")
    assert "2.50" in table  # speed-up against exact
    assert "fast" in tables.pareto_table(res) and "slow_and_bad" not in tables.pareto_table(res)
    assert "broken" in tables.failed_table(res)
    assert "abc1234" in tables.meta_text(res, "kfx sweep plan.json")


def test_jsonl_keeps_the_latest_record_and_skips_a_cut_line(tmp_path, capsys):
    path = tmp_path / "results.jsonl"
    older = record("exact", "room", 9.0, 10.0)
    lines = [json.dumps(older), json.dumps(RUNS[0]), '{"name": "cut', json.dumps(RUNS[1])]
    path.write_text("\n".join(lines) + "\n")
    res = results.Results(results.load_results(str(path)), None)
    assert results.ate_cm(res.get("exact", "room")) == pytest.approx(2.0)
    assert len(res.all) == 2
    assert "skipping malformed line 3" in capsys.readouterr().err


def test_csv_results_round_trip(tmp_path):
    path = tmp_path / "results.csv"
    path.write_text("name,group,sequence,backend,status,ate_rmse_m,computation_ms_mean,"
                    "track_ms_mean,baseline,settings\n"
                    "exact,exact,room,cpu,ok,0.02,10,5,true,\n"
                    "fast,fast,room,cpu,ok,0.022,4,2,false,icp_stride_px=4 raycast_rate=2\n")
    res = results.Results(results.load_results(str(path)), None)
    fast = res.get("fast", "room")
    assert results.ate_cm(fast) == pytest.approx(2.2)
    assert results.stage_ms(fast, "track") == 2
    assert fast["settings"] == ["icp_stride_px=4", "raycast_rate=2"]
    assert res.get("exact", "room")["baseline"] is True


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    ("{", "cannot read results"),
    ('{"runs": 3}', "no 'runs' list"),
])
def test_bad_results_files_raise_a_clear_error(tmp_path, content, message):
    path = tmp_path / "results.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ToolError, match=message):
        results.load_results(str(path))


def test_several_backends_need_a_choice(tmp_path):
    data = {"runs": [record("exact", "room", 2, 10), record("exact", "room", 2, 1,
                                                            backend="cuda")]}
    with pytest.raises(ToolError, match="pick one with --backend"):
        results.Results(data, None)
    with pytest.raises(ToolError, match="no results for backend 'metal'"):
        results.Results(data, "metal")
    assert results.Results(data, "cuda").get("exact", "room")["computation_ms"]["mean"] == 1


def test_template_keeps_readings_and_rejects_unknown_placeholders():
    existing = "<!-- reading:a -->kept by hand<!-- /reading:a -->"
    text = tables.fill_template("{{x}} <!-- reading:a -->draft<!-- /reading:a -->", {"x": "1"},
                                existing)
    assert text == "1 <!-- reading:a -->kept by hand<!-- /reading:a -->"
    with pytest.raises(ToolError, match="unknown"):
        tables.fill_template("{{nope}}", {}, "")


def write_plan(tmp_path, search_section, sequences=("a", "b")):
    plan = {"name": "t", "sequences": [{"name": s, "input": "synthetic:frames=5"}
                                       for s in sequences], "search": search_section}
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    return str(path)


def test_search_plan_objective_and_constraint(tmp_path):
    plan = search.SearchPlan(write_plan(tmp_path, {
        "knobs": {"icp_stride_px": {"int": [1, 4]},
                  "icp_robust": {"choices": ["off", "huber"]}},
        "objective": {"aggregate": "geomean"}, "constraint": {"ate_ratio": 1.1},
        "held_out": ["b"]}))
    assert [k.name for k in plan.knobs] == ["icp_stride_px", "icp_robust"]
    assert plan.search_sequences() == ["a"]
    measured = {"a": {"status": "ok", "end_to_end_frames_per_second": 400.0, "frames": 10,
                      "tracked": 9, "ate_rmse_m": 0.03},
                "b": {"status": "ok", "end_to_end_frames_per_second": 100.0, "frames": 10,
                      "tracked": 10, "ate_rmse_m": 0.01}}
    baseline = {"a": {"status": "ok", "frames": 10, "tracked": 10, "ate_rmse_m": 0.02},
                "b": {"status": "ok", "frames": 10, "tracked": 10, "ate_rmse_m": 0.01}}
    assert search.aggregate(plan, measured, ["a", "b"]) == pytest.approx(200.0)
    values, reasons = search.check(plan, measured, baseline, ["a", "b"])
    assert values == pytest.approx([1.5 - 1.1, 1.0, 1.0 - 1.1, 0.0])
    assert reasons == ["a ATE 1.50x", "a 1 more lost"]


@pytest.mark.parametrize("section, message", [
    ({"knobs": {}}, "search.knobs must be a non-empty object"),
    ({"knobs": {"k": {"int": [4, 1]}}}, "must be \\[low, high\\] with low < high"),
    ({"knobs": {"k": {"int": [1, 4]}}, "held_out": ["z"]}, "'z' is not a sequence"),
    ({"knobs": {"k": {"int": [1, 4]}}, "colour": 1}, "unknown field"),
])
def test_bad_search_plans_raise_a_clear_error(tmp_path, section, message):
    with pytest.raises(ToolError, match=message):
        search.SearchPlan(write_plan(tmp_path, section))


def test_search_summary_of_a_study_folder(tmp_path):
    assert search_summary.summary_lines(str(tmp_path)) == []  # nothing measured yet
    (tmp_path / "trials.json").write_text(json.dumps(
        {"trials": [{"feasible": True}, {"feasible": False}, {"feasible": True}]}))
    (tmp_path / "best.json").write_text(json.dumps({
        "trial": 2, "value": 1234.5, "worst_ate_ratio": 1.04, "set_arguments": "--set x=2",
        "results": {"a": {"end_to_end_frames_per_second": 1300.2, "ate_rmse_m": 0.0123,
                          "tracked": 500, "frames": 500}},
        "baseline": {"a": {"end_to_end_frames_per_second": 1000, "ate_rmse_m": 0.012,
                           "tracked": 500}}}))
    (tmp_path / "validation.json").write_text(json.dumps(
        {"held_out": {"holds": False, "reasons": ["b ATE 1.2x"], "worst_ate_ratio": 1.2}}))
    assert search_summary.summary_lines(str(tmp_path)) == [
        "trials: 3 (2 feasible)",
        "best: trial 2, 1234 frames/s (geomean), worst ATE ratio 1.04",
        "  --set x=2",
        "  a: 1300 frames/s (exact 1000), ATE 1.23 cm (exact 1.20), tracked 500/500 (exact 500)",
        "held out: does NOT hold: b ATE 1.2x; worst ATE ratio 1.2",
    ]


def test_ate_breakdown_alignment_removes_a_rigid_motion():
    gt = [[0.1 * i, 0.05 * i * i, 0.3 * math.sin(i)] for i in range(12)]
    c, s = math.cos(0.4), math.sin(0.4)
    moved = [[c * x - s * y + 1.0, s * x + c * y - 2.0, z + 0.5] for x, y, z in gt]
    errors, (rotation, _) = ate_breakdown.aligned_errors(moved, gt)
    assert len(errors) == len(gt)
    assert max(errors) < 1e-6
    assert rotation[0][1] == pytest.approx(s)  # the inverse motion: rotation by -0.4
    assert ate_breakdown.rms([3.0, 4.0]) == pytest.approx(math.sqrt(12.5))


def bench_json(path, joules_per_frame, idle=True, available=True):
    """A `kfx bench --json` result with the energy fields the table reads."""
    gpu = {"available": False, "reason": "no NVML here"}
    if available:
        gpu = {"available": True, "joules_per_frame": joules_per_frame,
               "frames_per_joule": 1.0 / joules_per_frame, "mean_watts": 300.0, "seconds": 4.0,
               "method": "nvml"}
        if idle:
            gpu.update({"idle": {"mean_watts": 100.0},
                        "above_idle_joules_per_frame": joules_per_frame * 0.5})
    path.write_text(json.dumps({"frames": 500, "repeat": 8, "energy": {
        "gpu": gpu, "cpu": {"available": False, "reason": "no RAPL"}}}))


def test_energy_table_means_and_spread(tmp_path):
    for rep, j in enumerate((0.040, 0.050, 0.060), 1):
        bench_json(tmp_path / f"icl_exact_{rep}.json", j)
        bench_json(tmp_path / f"icl_fast_{rep}.json", j, available=False)
    text = energy.energy_table(str(tmp_path), ["icl"], "exact fast", 3, "1.5", "H200", "abc1234",
                               "60")
    row = next(line for line in text.splitlines() if line.startswith("| icl | exact |"))
    # mean 50 mJ/frame, 20.6 frames/J (mean of 25, 20, 16.7), idle 100 W, 25 mJ above idle
    # (41.1 frames/J: mean of 50, 40, 33.3),
    # spread (60 - 40) / 50 = 40 %.
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[2:10] == ["500 × 8 (4.0)", "50.000", "20.6", "300", "100", "25.000", "41.1",
                           "40.0 %"]
    assert "| icl | fast | 500 × 8 | no NVML here |" in text
    assert "Host CPU energy on this machine: no RAPL." in text
    assert "Commit: `abc1234`" in text
    with pytest.raises(ToolError, match="cannot read the bench results"):
        energy.energy_table(str(tmp_path), ["tum"], "exact", 1, "1", "", "", "")


def test_import_kfx_needs_neither_matplotlib_nor_optuna():
    code = ("import sys, kfx, kfx.study.results, kfx.study.search, kfx.study.tables, "
            "kfx.study.thesis, kfx.study.energy, kfx.study.soak, kfx.study.ate_breakdown, "
            "kfx.study.search_summary, "
            "kfx.plots.sweep, kfx.plots.presets; "
            "print(sorted(m for m in ('matplotlib', 'optuna') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_missing_matplotlib_is_a_clear_error():
    # matplotlib made unimportable in a child interpreter.
    code = ("import sys; sys.modules['matplotlib'] = None\n"
            "import kfx.plots\n"
            "try:\n    kfx.plots.import_pyplot()\n"
            "except kfx.study.ToolError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "matplotlib is not installed" in out and "--no-plots" in out


def test_plot_sweep_without_plots_writes_tables(results_json, tmp_path):
    from kfx.plots import sweep

    out = tmp_path / "out"
    assert sweep.main([str(results_json), "--out", str(out), "--no-plots"]) in (None, 0)
    text = (out / "tables.md").read_text()
    assert "## fast" in text and "## slow_and_bad" in text and "## failed runs" in text
    assert not list(out.glob("*.png"))


def test_plot_sweep_draws_figures(results_json, tmp_path):
    pytest.importorskip("matplotlib", reason="matplotlib not installed: figures not drawn")
    from kfx.plots import sweep

    out = tmp_path / "out"
    sweep.main([str(results_json), "--out", str(out)])
    for name in ("step_stride.png", "pareto.png", "before_after.png"):
        png = out / name
        assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


def test_a_tiny_kfx_sweep_read_back(tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built (KFX_CLI or build/release/kfx)")
    plan = {"name": "tiny", "baseline": "exact", "repeat": 1, "warmup_frames": 0,
            "settings": {"volume_resolution": 64},
            "sequences": [{"name": "room", "input": "synthetic:frames=8,width=128,height=96"}],
            "runs": [{"name": "exact", "preset": "exact"},
                     {"name": "stride_4", "settings": {"icp_stride_px": 4}}]}
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(plan))
    subprocess.run([str(cli), "sweep", str(plan_path), "--out", str(tmp_path / "sweep"),
                    "--backend", "cpu", "--idle-seconds", "0", "--commit", "test"], check=True,
                   capture_output=True)
    res = results.Results(results.load_results(str(tmp_path / "sweep")), None)
    assert sorted(res.names) == ["exact", "stride_4"] and res.sequences == ["room"]
    for name in res.names:
        r = res.get(name, "room")
        assert r["frames"] == 8 and results.computation_ms(r) > 0
        assert results.ate_cm(r) is not None and results.ate_cm(r) >= 0
    assert "stride_4" in tables.before_after_table(res, "stride_4")


def test_checkout_commands_run_the_package(results_json, tmp_path):
    """scripts/plot_sweep.py runs kfx.plots.sweep from the checkout, built or not."""
    script = ROOT / "scripts" / "plot_sweep.py"
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, str(script), str(results_json), "--out", str(out),
                          "--no-plots"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert (out / "tables.md").exists()
    run = subprocess.run([sys.executable, str(script), str(tmp_path / "none.json")],
                         capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=""))
    assert run.returncode == 2
    assert "plot_sweep.py: error:" in run.stderr and "no such file" in run.stderr
