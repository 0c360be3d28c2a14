"""Issue 46's live figures, measured in one go (prints JSON; nothing here is a stored figure):

1. a RealSense recording of icl_office_kt0 made at 30 Hz (pyrealsense2's recorder) played at
   real time as the camera: frames received, processed and dropped on ``--backend`` and on the
   CPU (``kfx.live.run``);
2. what the Rerun view costs the frame loop: the folder's frames through a Reconstruction with
   and without ``kfx.viewer.Viewer`` (to an .rrd file), alternated ``--repeat`` times, median
   loop time of each.

    build/venv/bin/python bench/live_bench.py --backend cuda [--frames 300] [--repeat 3]
"""

import argparse
import json
import pathlib
import statistics
import tempfile
import time

import kfx
import kfx.live
import kfx.recordings
from kfx.viewer import Viewer

ROOT = pathlib.Path(__file__).resolve().parents[1]


def live(recording, backend, out):
    stats = kfx.live.run(str(out), str(recording), backend=backend, mesh=False)
    return {k: getattr(stats, k) for k in ("frames_received", "frames_processed",
                                           "frames_dropped", "frames_missed", "max_queue_depth",
                                           "processed_per_s")}


def loop_seconds(folder, frames, backend, view, rrd):
    sequence = kfx.open(str(folder))
    r = kfx.Reconstruction(sequence, backend=backend)
    viewer = Viewer(str(rrd)) if view else None
    started = time.perf_counter()
    for n, frame in enumerate(sequence):
        if n == frames:
            break
        result = r.process(frame)
        if viewer is not None:
            viewer.submit(r, frame, result)
    seconds = time.perf_counter() - started
    return seconds, (viewer.close() if viewer is not None else {})


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--folder", default=str(ROOT.parent / "shared/data/icl_office_kt0"))
    parser.add_argument("--backend", default="auto")
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="kfx_live_bench_"))
    recording = work / "camera.db3"
    kfx.recordings.write_realsense_bag(args.folder, str(recording), args.frames, fps=30,
                                       paced=True)
    result = {"frames": args.frames, "backend": args.backend,
              "real_time": live(recording, args.backend, work / "live"),
              "real_time_cpu": live(recording, "cpu", work / "live_cpu")}
    without, with_view, views = [], [], []
    for _ in range(args.repeat):
        without.append(loop_seconds(args.folder, args.frames, args.backend, False, None)[0])
        seconds, view = loop_seconds(args.folder, args.frames, args.backend, True,
                                     work / "view.rrd")
        with_view.append(seconds)
        views.append(view)
    base, viewed = statistics.median(without), statistics.median(with_view)
    result["view"] = {"loop_s_without": without, "loop_s_with": with_view,
                      "overhead_percent": round(100 * (viewed - base) / base, 2),
                      "viewer": views[-1]}
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
