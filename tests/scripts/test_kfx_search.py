#!/usr/bin/env python3
"""End-to-end test of the search mode (scripts/kfx_search, which runs kfx.study.search;
docs/sweep.md "Search") on the CPU.

A tiny search: two knobs, two 20-frame synthetic sequences at 128x96 in a 64^3 volume, one held
out. The first two trials are queued: the baseline's own configuration (must be feasible) and
one ICP level with a 16-pixel stride (breaks tracking: must be infeasible). It checks that
`kfx sweep` points a search plan to kfx_search; that the search runs, writes trials.csv,
trials.json, best.json and validation.json; that a second invocation adds trials to the same
study; the robustness step (neighbours, shifted start frames); and shifted copies of a TUM
folder and a .raw file.

Usage: test_kfx_search.py KFX_BINARY SOURCE_DIR
Exit status: 0 pass, 1 failure, 77 skipped (optuna not importable).
"""

import csv
import importlib
import json
import os
import subprocess
import sys
import tempfile

SKIP = 77

try:
    import optuna  # noqa: F401
except ImportError:
    # CMake may have found an interpreter without optuna (e.g. a pyenv one); the system one
    # has it when scripts/setup ran, so try that once before skipping.
    SYSTEM_PYTHON = "/usr/bin/python3"
    if (os.path.realpath(sys.executable) != os.path.realpath(SYSTEM_PYTHON)
            and os.access(SYSTEM_PYTHON, os.X_OK)
            and os.environ.get("KFX_SEARCH_TEST_REEXEC") != "1"):
        os.environ["KFX_SEARCH_TEST_REEXEC"] = "1"
        os.execv(SYSTEM_PYTHON, [SYSTEM_PYTHON] + sys.argv)
    print("SKIP: optuna is not importable by", sys.executable,
          "(Debian: python3-optuna, installed by scripts/setup)")
    sys.exit(SKIP)

FAILURES = []


def expect(condition, message):
    if not condition:
        FAILURES.append(message)
        print("FAIL:", message)


def load_search_module(source_dir):
    """kfx.study.search from the checkout's python/kfx (as scripts/kfx_search runs it)."""
    sys.path.insert(0, os.path.join(source_dir, "scripts"))
    import checkout_package

    checkout_package.use_checkout_package()
    return importlib.import_module("kfx.study.search")


PLAN = {
    "name": "tiny_search",
    "repeat": 1,
    "warmup_frames": 0,
    "settings": {"volume_resolution": 64, "compute_size_ratio": 1},
    "sequences": [
        {"name": "a", "input": "synthetic:frames=20,width=128,height=96"},
        {"name": "b", "input": "synthetic:frames=20,width=128,height=96,seed=2"},
        {"name": "hard", "input": "synthetic:frames=20,width=128,height=96,speed=2,seed=3"},
    ],
    "search": {
        "knobs": {"pyramid_iterations": {"choices": ["10,5,4", "1"]},
                  "icp_stride_px": {"choices": [1, 16]}},
        "enqueue": [{"pyramid_iterations": "10,5,4", "icp_stride_px": 1},
                    {"pyramid_iterations": "1", "icp_stride_px": 16}],
        "trials": 2,
        "sampler": {"name": "tpe", "seed": 1, "startup_trials": 2},
        "held_out": ["hard"],
    },
}


def run_search(script, plan_path, out, kfx, *extra):
    command = [sys.executable, script, plan_path, "--out", out, "--kfx", kfx,
               "--backend", "cpu", *extra]
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, OMP_NUM_THREADS="1"))
    print(result.stderr)
    expect(result.returncode == 0, f"kfx_search {' '.join(extra)} exited {result.returncode}")
    return result.stderr


def test_shifted_copies(module, tmp):
    tum = os.path.join(tmp, "tum_fr1_toy")
    os.makedirs(os.path.join(tum, "depth"))
    with open(os.path.join(tum, "depth.txt"), "w") as f:
        f.write("# depth maps\n# file: toy\n# timestamp filename\n")
        for i in range(5):
            f.write(f"{i}.0 depth/{i}.png\n")
    open(os.path.join(tum, "groundtruth.txt"), "w").close()
    copy = module.shifted_copy(tum, 2, os.path.join(tmp, "shifted"), "unused")
    with open(os.path.join(copy, "depth.txt")) as f:
        lines = f.read().splitlines()
    expect(lines[:3] == ["# depth maps", "# file: toy", "# timestamp filename"],
           "a shifted TUM listing keeps its header lines")
    expect(lines[3:] == ["2.0 depth/2.png", "3.0 depth/3.png", "4.0 depth/4.png"],
           f"a TUM listing shifted by 2 keeps frames 2..4, got {lines[3:]}")
    expect(os.path.islink(os.path.join(copy, "depth")) and
           os.path.islink(os.path.join(copy, "groundtruth.txt")),
           "a shifted TUM folder links the original images and ground truth")
    # A .raw of 3 frames of 2x1 pixels, with a sidecar of stamps.
    raw = os.path.join(tmp, "toy.raw")
    with open(raw, "wb") as f:
        for frame in range(3):
            size = (2).to_bytes(4, "little") + (1).to_bytes(4, "little")
            f.write(size + bytes([frame, 0, frame, 0]) + size + bytes([frame] * 6))
    with open(raw + ".json", "w") as f:
        json.dump({"stamps": [10.0, 11.0, 12.0], "source": "toy"}, f)
    copy = module.shifted_copy(raw, 1, os.path.join(tmp, "shifted"), "unused")
    with open(copy, "rb") as f:
        data = f.read()
    expect(len(data) == 2 * 26 and data[8] == 1 and data[26 + 8] == 2,
           "a .raw shifted by 1 holds frames 1 and 2")
    with open(copy + ".json") as f:
        expect(json.load(f)["stamps"] == [11.0, 12.0], "a shifted .raw's sidecar drops a stamp")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 1
    kfx, source_dir = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    script = os.path.join(source_dir, "scripts", "kfx_search")
    with tempfile.TemporaryDirectory(prefix="kfx_search_test_") as tmp:
        test_shifted_copies(load_search_module(source_dir), tmp)
        plan_path = os.path.join(tmp, "tiny_search.json")
        with open(plan_path, "w") as f:
            json.dump(PLAN, f)
        out = os.path.join(tmp, "out")

        # kfx sweep does not run a search plan: it names the command that does.
        result = subprocess.run([kfx, "sweep", plan_path, "--out", out, "--backend", "cpu"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        expect(result.returncode != 0 and "scripts/kfx_search " + plan_path in result.stderr,
               f"kfx sweep on a search plan should name scripts/kfx_search: {result.stderr}")

        run_search(script, plan_path, out, kfx)
        for name in ("trials.csv", "trials.json", "best.json", "validation.json", "study.db"):
            expect(os.path.exists(os.path.join(out, name)), f"{name} written")
        with open(os.path.join(out, "trials.json")) as f:
            first = json.load(f)["trials"]
        expect([t["number"] for t in first] == [0, 1], "first invocation: trials 0 and 1")
        if len(first) == 2:
            expect(first[0]["feasible"], f"the baseline's own configuration is feasible: "
                   f"{first[0]['reasons']}")
            expect(not first[1]["feasible"] and first[1]["reasons"],
                   "one ICP level with a 16-pixel stride is infeasible, with a reason")
        with open(os.path.join(out, "best.json")) as f:
            best = json.load(f)
        expect(best["trial"] == 0 and best["settings"] == {"pyramid_iterations": "10,5,4",
                                                           "icp_stride_px": "1"},
               f"best.json names the only feasible trial: {best.get('settings')}")
        with open(os.path.join(out, "validation.json")) as f:
            validation = json.load(f)
        expect(validation["held_out"].get("holds") is True,
               "the baseline's own configuration holds on the held-out sequence")

        # Resume: the same study grows to 4 trials; the first two are kept as they were.
        stderr = run_search(script, plan_path, out, kfx, "--trials", "4", "--robustness",
                            "--top", "1", "--start-frames", "5")
        expect("2 trials done" in stderr, "the second invocation continues the stored study")
        with open(os.path.join(out, "trials.json")) as f:
            second = json.load(f)["trials"]
        expect([t["number"] for t in second] == [0, 1, 2, 3], "second invocation: trials 0..3")
        expect(second[:2] == first, "the resumed study keeps the first trials unchanged")
        with open(os.path.join(out, "trials.csv")) as f:
            rows = list(csv.DictReader(f))
        expect(len(rows) == 4 and "a_ate_m" in rows[0] and "icp_stride_px" in rows[0],
               "trials.csv has one row per trial with knobs and per-sequence ATE")
        study = optuna.load_study(study_name="tiny_search",
                                  storage="sqlite:///" + os.path.join(out, "study.db"))
        expect(len(study.trials) == 4, f"one study of 4 trials in study.db, {len(study.trials)}")
        with open(os.path.join(out, "robustness.json")) as f:
            robust = json.load(f)
        candidate = robust["candidates"][0] if robust["candidates"] else {}
        expect(len(candidate.get("neighbours", [])) == 3,
               "robustness: the trial itself and one neighbour per knob")
        expect(set(candidate.get("start_frames", {}).get("results", {})) == {"a_from5", "b_from5"},
               "robustness: each search sequence again from frame 5")
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed")
        return 1
    print("kfx_search: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
