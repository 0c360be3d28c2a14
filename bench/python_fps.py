#!/usr/bin/env python3
"""Frames/s of a Python loop feeding kfx, against `kfx bench` on the same sequence and device.

Times what `kfx bench` times (apps/timed_passes.cpp): the frames read into memory first, a
warm-up of 30 frames, then passes over every frame, each from a reset reconstruction, with one
frame in flight (submit frame f+1, then collect frame f); a pass's frames/s is its frames over
its wall time; the median over passes is reported. ROUNDS rounds alternate `kfx bench --repeat
REPEAT` and REPEAT Python passes. The Python loop feeds numpy
uint16 millimetre arrays (the caller's own memory, no copy) or, with --frames-as-read, the
kfx.Frame objects a Sequence yields.

With --kfx PATH it runs `PATH bench` with the same settings first and prints both and the
ratio; with --trajectory-check DIR it also writes DIR/python_trajectory.txt from the last pass
(and `kfx run` with the same settings writes DIR/cli/trajectory.txt) and says whether they are
byte-identical. Exit status 0 unless something failed to run.

    python3 bench/python_fps.py INPUT --backend cuda --repeat 5 --kfx build/gpu/kfx \\
        [--set key=value ...] [--json OUT.json] [--trajectory-check DIR]
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import kfx


class PythonLoop:
    """The frames in memory and a warmed-up reconstruction; passes() times REPEAT passes."""

    def __init__(self, args, settings):
        sequence = kfx.open(args.input)
        self.frames = list(sequence)
        if args.frames:
            self.frames = self.frames[: args.frames]
        self.depths = [np.array(f.depth) for f in self.frames]
        self.stamps = [f.stamp for f in self.frames]
        self.as_read = args.frames_as_read
        self.r = kfx.Reconstruction(sequence, settings=settings)
        for i in range(min(30, len(self.frames))):  # warm-up (records the GPU's frame graphs)
            self.r.process(self.frames[i])

    def passes(self, repeat):
        r = self.r
        fps = []
        for _ in range(repeat):
            r.reset()
            submit, collect = r.submit, r.collect
            start = time.perf_counter()
            if self.as_read:
                for f in self.frames:
                    submit(f)
                    if r.frames_in_flight > 1:
                        collect()
            else:
                for depth, stamp in zip(self.depths, self.stamps):
                    submit(depth, stamp)
                    if r.frames_in_flight > 1:
                        collect()
            while r.frames_in_flight:
                collect()
            fps.append(len(self.frames) / (time.perf_counter() - start))
        return fps


def kfx_bench_passes(args):
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [args.kfx, "bench", args.input, "--backend", args.backend, "--preset",
               args.preset, "--repeat", str(args.repeat), "--json", tmp + "/bench.json"]
        cmd += [x for a in args.set for x in ("--set", a)]
        if args.frames:
            cmd += ["--frames", str(args.frames)]
        subprocess.run(cmd, check=True, capture_output=True)
        with open(tmp + "/bench.json") as f:
            return json.load(f)["end_to_end_frames_per_second_passes"]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("input")
    p.add_argument("--backend", default="auto")
    p.add_argument("--preset", default="exact")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--repeat", type=int, default=5, help="timed passes per round")
    p.add_argument("--rounds", type=int, default=3,
                   help="rounds, each `kfx bench --repeat REPEAT` then REPEAT Python passes")
    p.add_argument("--frames", type=int, default=0, help="first N frames only (0 = all)")
    p.add_argument("--frames-as-read", action="store_true",
                   help="feed kfx.Frame objects instead of numpy arrays")
    p.add_argument("--kfx", help="the kfx CLI, to run `kfx bench` on the same sequence first")
    p.add_argument("--json", help="write the figures here")
    p.add_argument("--trajectory-check", metavar="DIR")
    args = p.parse_args()

    settings = kfx.Settings(args.preset)
    settings.backend = args.backend
    for assignment in args.set:
        key, _, value = assignment.partition("=")
        settings.set(key, value)

    result = {"input": args.input, "backend": args.backend, "preset": args.preset,
              "settings": args.set, "repeat": args.repeat, "rounds": args.rounds,
              "kfx_version": kfx.version()}
    loop = PythonLoop(args, settings)
    r = loop.r
    # Rounds alternate the two, so that a machine's slow minute weighs on both alike.
    python_fps, bench_fps = [], []
    for _ in range(args.rounds):
        if args.kfx:
            bench_fps += kfx_bench_passes(args)
        python_fps += loop.passes(args.repeat)
    n = len(loop.frames)
    result.update(frames=n, device=r.device, python_fps_median=statistics.median(python_fps),
                  python_fps_passes=python_fps)
    print(f"python loop: {result['python_fps_median']:.1f} frames/s (median of "
          f"{len(python_fps)} passes, {n} frames, {r.backend} on {r.device})")
    if args.kfx:
        result["kfx_bench_fps_median"] = statistics.median(bench_fps)
        result["kfx_bench_fps_passes"] = bench_fps
        ratio = result["python_fps_median"] / result["kfx_bench_fps_median"]
        result["ratio"] = ratio
        print(f"kfx bench:   {result['kfx_bench_fps_median']:.1f} frames/s (median of "
              f"{len(bench_fps)} passes); python / bench = {100 * ratio:.1f} %")

    if args.trajectory_check:
        out = args.trajectory_check
        r.save_trajectory(out + "/python_trajectory.txt", args.input)
        if args.kfx:
            cmd = [args.kfx, "run", args.input, "--backend", args.backend, "--preset",
                   args.preset, "-q", "--no-mesh", "--no-report", "--overwrite",
                   "--out", out + "/cli"]
            cmd += [x for a in args.set for x in ("--set", a)]
            if args.frames:
                cmd += ["--frames", str(args.frames)]
            subprocess.run(cmd, check=True, capture_output=True)
            with open(out + "/cli/trajectory.txt", "rb") as a, \
                 open(out + "/python_trajectory.txt", "rb") as b:
                same = a.read() == b.read()
            result["trajectory_identical_to_cli"] = same
            print(f"trajectory: python and kfx run are {'' if same else 'NOT '}byte-identical")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
