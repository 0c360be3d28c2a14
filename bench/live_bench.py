"""Issue 46's live figures, measured in one go (prints JSON; nothing here is a stored figure):

1. a RealSense recording of INPUT made at 30 Hz by pyrealsense2's recorder (on the spot, so a
   machine without the datasets can run it) played at real time as the camera
   (``set_real_time(True)``): frames received, processed and dropped on ``--backend``, with
   and without the Rerun view, and on the CPU (``kfx.live.run``); with ``--openni``, an OpenNI2
   ``.oni`` of INPUT's frames at 30 Hz (tests/python/oni_writer.py) played by OpenNI2 as the
   device at its recorded pace instead (``kfx.live.run(openni=...)``, no pyrealsense2);
2. what the Rerun view costs the frame loop: INPUT's frames through a Reconstruction with and
   without ``kfx.viewer.Viewer`` (to an .rrd file), the two alternated ``--repeat`` times;
   median loop time of each, and the overhead of the medians.

    build/venv/bin/python bench/live_bench.py --backend cuda \\
        [--input synthetic:width=640,height=480,frames=300] [--repeat 3] [--no-real-time]
        [--openni]
"""

import argparse
import itertools
import json
import math
import os
import pathlib
import platform
import resource
import statistics
import sys
import tempfile
import time

import numpy as np

import kfx
import kfx.live
import kfx.recordings
from kfx.viewer import Viewer


def live(recording, backend, out, view=None, openni=False):
    viewer = Viewer(str(view)) if view else None
    if openni:
        stats = kfx.live.run(str(out), openni=str(recording), backend=backend, mesh=False,
                             viewer=viewer)
    else:
        stats = kfx.live.run(str(out), str(recording), backend=backend, mesh=False,
                             viewer=viewer)
    figures = {k: getattr(stats, k) for k in ("frames_received", "frames_processed",
                                              "frames_dropped", "frames_missed",
                                              "max_queue_depth", "processed_per_s")}
    if viewer is not None:
        figures["viewer"] = stats.viewer
    return figures


def write_paced_oni(source, path, frames):
    """An OpenNI2 recording of `source`'s first `frames` frames, stamped 1/30 s apart."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests" / "python"))
    from oni_writer import write_oni  # noqa: PLC0415 (the tests' writer: no recorder is here)

    sequence = kfx.open(source)
    camera = sequence.camera
    read = list(itertools.islice(sequence, frames))
    colour = np.stack([f.colour for f in read]) if read[0].colour is not None else None
    write_oni(str(path), np.stack([f.depth for f in read]),
              [round(i * 1e6 / 30) for i in range(len(read))],
              2 * math.atan(camera.width / 2 / camera.fx),
              2 * math.atan(camera.height / 2 / abs(camera.fy)), colour=colour)


def loop_seconds(source, frames, backend, view, rrd, settings):
    """The loop over `frames` (read beforehand: reading, a synthetic scene's rendering above all,
    would dilute the view's share) with or without the view."""
    r = kfx.Reconstruction(kfx.open(source), backend=backend, **settings)
    viewer = Viewer(str(rrd)) if view else None
    cpu = _cpu_seconds()
    started = time.perf_counter()
    for frame in frames:
        result = r.process(frame)
        if viewer is not None:
            viewer.submit(r, frame, result)
    seconds = time.perf_counter() - started
    loop_cpu = _cpu_seconds()[0] - cpu[0]
    stats = viewer.close() if viewer is not None else {}
    # The viewer process's CPU time, its start and its final mesh included (it is waited for
    # by close()): what the view takes from the machine, whatever else runs on it.
    stats["process_cpu_s"] = round(_cpu_seconds()[1] - cpu[1], 3)
    stats["loop_cpu_s"] = round(loop_cpu, 3)
    return seconds, stats


def _cpu_seconds():
    """(this process's CPU seconds, its waited-for children's)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--input", default="synthetic:width=640,height=480,frames=300")
    parser.add_argument("--backend", default="auto")
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="settings for the loop's reconstructions (repeatable)")
    parser.add_argument("--no-real-time", action="store_true",
                        help="only the view's cost (no pyrealsense2 recording and playback)")
    parser.add_argument("--openni", action="store_true",
                        help="play an OpenNI2 .oni of INPUT as the device (no pyrealsense2)")
    parser.add_argument("--json", default="", help="also write the result here")
    args = parser.parse_args()
    settings = dict(pair.split("=", 1) for pair in args.set)
    work = pathlib.Path(tempfile.mkdtemp(prefix="kfx_live_bench_"))
    result = {"input": args.input, "frames": args.frames, "backend": args.backend,
              "settings": settings, "machine": platform.node(), "cpus": os.cpu_count(),
              "commit": os.environ.get("KFX_COMMIT", "")}
    if not args.no_real_time:
        recording = work / ("camera.oni" if args.openni else "camera.db3")
        started = time.monotonic()
        if args.openni:
            write_paced_oni(args.input, recording, args.frames)
        else:
            kfx.recordings.write_realsense_bag(args.input, str(recording), args.frames, fps=30,
                                               paced=True)
        result["recording"] = "OpenNI2 .oni" if args.openni else "RealSense (pyrealsense2)"
        result["recorded_s"] = round(time.monotonic() - started, 2)
        result["real_time"] = live(recording, args.backend, work / "live", openni=args.openni)
        result["real_time_with_view"] = live(recording, args.backend, work / "live_view",
                                             work / "live.rrd", openni=args.openni)
        result["real_time_cpu"] = live(recording, "cpu", work / "live_cpu", openni=args.openni)
    frames = list(itertools.islice(kfx.open(args.input), args.frames))
    without, with_view, views, plain = [], [], [], []
    for _ in range(args.repeat):
        seconds, stats = loop_seconds(args.input, frames, args.backend, False, None,
                                      settings)
        without.append(seconds)
        plain.append(stats["loop_cpu_s"])
        seconds, view = loop_seconds(args.input, frames, args.backend, True,
                                     work / "view.rrd", settings)
        with_view.append(seconds)
        views.append(view)
    base, viewed = statistics.median(without), statistics.median(with_view)
    result["view"] = {"loop_s_without": [round(s, 3) for s in without],
                      "loop_s_with": [round(s, 3) for s in with_view],
                      "overhead_percent": round(100 * (viewed - base) / base, 2),
                      "loop_cpu_s_without": plain,
                      "loop_cpu_s_with": [v["loop_cpu_s"] for v in views],
                      "viewer_process_cpu_s": [v["process_cpu_s"] for v in views],
                      "viewer": views[-1]}
    text = json.dumps(result, indent=2)
    print(text, flush=True)
    if args.json:
        pathlib.Path(args.json).write_text(text + "\n")


if __name__ == "__main__":
    main()
