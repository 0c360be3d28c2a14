#!/usr/bin/env python3
"""report.html in a real browser: kfx runs a small synthetic sequence with renders, a small mesh
of mesh.ply's layout is put beside it, `kfx report` makes the page and headless Chromium (WebGL
through SwiftShader) loads it. Checks: no script error, the 3D view draws the model (the page
counts its own non-background pixels with the camera path hidden), the plots and renders are
there; and for a run whose tracking fails, without mesh.ply, the page says the mesh is missing,
still works, draws no model and marks the lost frames. The summary must say what stats.json
says (frames, tracked, lost and the frames marked, frames/s, ATE, RPE, the y flip) for a run with
ground truth, one whose intrinsics mirror y, one without ground truth and one with
bootstrap_frames=1.

Usage: test_report_browser.py KFX_BINARY. Exit 77 (skipped) when Chromium is not installed."""

import json
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

SKIP = 77


def find_chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def write_sphere_ply(path, centre, radius, rings=24, segments=48):
    """A UV sphere in kfx's mesh.ply layout (binary little-endian, float x y z nx ny nz, faces
    as list uchar int), shared vertices."""
    vertices, faces = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2 * math.pi * j / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            vertices.append(tuple(c + radius * d for c, d in zip(centre, n)) + n)
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            if i > 0:
                faces.append((a, b, c))
            if i < rings - 1:
                faces.append((b, d, c))
    header = ("ply\nformat binary_little_endian 1.0\ncomment test sphere\n"
              f"element vertex {len(vertices)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as f:
        f.write(header.encode())
        for v in vertices:
            f.write(struct.pack("<6f", *v))
        for face in faces:
            f.write(struct.pack("<B3i", 3, *face))


def first_camera_position(trajectory_path):
    with open(trajectory_path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                return [float(v) for v in line.split()[1:4]]
    raise AssertionError(f"{trajectory_path}: no pose")


def load_page(chromium, page, workdir):
    """The page's DOM after its scripts ran, and the browser's log (console messages)."""
    command = [chromium, "--headless", "--no-sandbox", "--no-first-run", "--disable-extensions",
               "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
               "--enable-logging=stderr", "--v=0", f"--user-data-dir={workdir}/profile",
               "--window-size=1200,1800", "--virtual-time-budget=10000", "--dump-dom",
               "file://" + os.path.abspath(page)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=90)
    assert result.returncode == 0, f"chromium failed ({result.returncode}):\n{result.stderr[-3000:]}"
    return result.stdout, result.stderr


def body_attributes(dom):
    body = re.search(r"<body([^>]*)>", dom)
    assert body, "no <body> in the dumped DOM"
    return dict(re.findall(r'([\w-]+)="([^"]*)"', body.group(1)))


def summary_rows(dom):
    """The summary table as {label: text}, as the page shows it."""
    table = re.search(r'<table class="summary" id="summary">(.*?)</table>', dom, re.S)
    assert table, "no summary table in the dumped DOM"
    return {re.sub(r"<[^>]+>", "", label).strip(): re.sub(r"<[^>]+>", "", value).strip()
            for label, value in re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td></tr>", table.group(1), re.S)}


def number_after(text, prefix=""):
    """The first number in text after prefix; NaN (equal to nothing) when there is none."""
    match = re.search(re.escape(prefix) + r"\s*(-?[0-9]+(?:\.[0-9]+)?)", text)
    return float(match.group(1)) if match else math.nan


def check_summary_against_stats(check, name, dom, stats):
    """What the page SAYS equals stats.json: frames, tracked, lost (and the frames marked lost),
    frames/s, ATE and RPE (or that there is no ground truth), and the error plot's RMSE equals
    the ATE (the plots are aligned as the ATE was, y flip included), and the block map's memory
    row (blocks, MiB, budget, blocks swapped, frames short of blocks)."""
    rows = summary_rows(dom)
    check(rows.get("Frames") == str(stats["frames"]), f"{name}: Frames {rows.get('Frames')!r}, stats {stats['frames']}")
    check(number_after(rows.get("Tracked", "")) == stats["tracked"],
          f"{name}: Tracked {rows.get('Tracked')!r}, stats {stats['tracked']}")
    check(number_after(rows.get("Tracking lost", "")) == stats["lost"],
          f"{name}: Tracking lost {rows.get('Tracking lost')!r}, stats {stats['lost']}")
    fps = rows.get("Frames/s (1 / mean computation time)", "")
    # One decimal, as the terminal's summary line rounds it.
    check(fps == f"{stats['frames_per_second']:.1f}",
          f"{name}: Frames/s {fps!r}, stats {stats['frames_per_second']}")
    plots = re.findall(r'<svg class="plot".*?</svg>', dom, re.S)
    # Every plot's legend sits above its plot area, never over its lines.
    for p in plots:
        area = re.search(r'<rect x="[^"]+" y="([0-9.]+)"', p)
        if area is None:  # the script's own text, which the DOM holds too
            continue
        area_top = float(area.group(1))
        for y in re.findall(r'<text class="legend" x="[^"]+" y="([0-9.]+)"', p):
            check(float(y) < area_top, f"{name}: a legend at y {y} inside the plot area (top {area_top})")
    # The warnings section lists every stretch of stats.json's warning_stretches, in order.
    section = re.search(r'<div id="warnings">(.*?)</div>', dom, re.S)
    listed = re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td></tr>", section.group(1) if section else "")
    expected = [(w["description"], str(w["first_frame"]) if w["first_frame"] == w["last_frame"]
                 else f"{w['first_frame']}–{w['last_frame']}", str(w["frames"]))
                for w in stats["warning_stretches"]]
    check(listed == expected, f"{name}: warnings listed {listed}, stats.json {expected}")
    if not expected:
        check(section is not None and "No warnings" in section.group(1), f"{name}: no 'No warnings' note")
    # The tracking state: stats.json's counts, and its stretches of poor and lost frames in order.
    start = dom.find('<div id="tracking-states">')
    states = dom[start:dom.find("<h2>", start)] if start >= 0 else ""
    t = stats.get("tracking_states")
    check(t is not None, f"{name}: stats.json has no tracking_states")
    if t is not None:
        counts = f"good {t['good']}, poor {t['poor']}, lost {t['lost']} frame(s)"
        check(counts in states, f"{name}: tracking state section lacks {counts!r}")
        listed = re.findall(r"<tr><td>(good|poor|lost)</td><td>(.*?)</td><td>(.*?)</td></tr>", states)
        expected = [(s["state"], str(s["first_frame"]) if s["first_frame"] == s["last_frame"]
                     else f"{s['first_frame']}–{s['last_frame']}", str(s["frames"]))
                    for s in t["stretches"]]
        check(listed == expected, f"{name}: tracking stretches listed {listed}, stats.json {expected}")
    stage_plots = [p for p in plots if "Stage times" in p]
    check(len(stage_plots) == 1, f"{name}: {len(stage_plots)} stage-time plots")
    if stage_plots:
        marked = len(re.findall(r'class="lost"', stage_plots[0]))
        check(marked == stats["lost"], f"{name}: {marked} frames marked lost, stats.json counts {stats['lost']}")
    ate_rows = [label for label in rows if label.startswith("ATE")]
    if "ate_rmse_m" in stats:
        label = next((l for l in ate_rows if "RMSE" in l), None)
        check(label is not None, f"{name}: no ATE RMSE row (rows: {list(rows)})")
        if label:
            check(abs(number_after(rows[label]) - 100 * stats["ate_rmse_m"]) <= 0.0051,
                  f"{name}: ATE {rows[label]!r}, stats {100 * stats['ate_rmse_m']:.4f} cm")
            check(("y flipped" in label) == stats["ate_flip_y"], f"{name}: ATE label {label!r}, flip {stats['ate_flip_y']}")
        rpe = next((l for l in rows if l.startswith("RPE")), None)
        check(rpe is not None, f"{name}: no RPE row (rows: {list(rows)})")
        if rpe:
            check(abs(number_after(rows[rpe]) - 100 * stats["rpe_translation_rmse_m"]) <= 0.0051,
                  f"{name}: RPE {rows[rpe]!r}, stats {100 * stats['rpe_translation_rmse_m']:.4f} cm")
        error_plot = next((p for p in plots if "Translational error" in p), "")
        check(error_plot != "", f"{name}: no translational error plot")
        if error_plot:
            plotted = number_after(error_plot, "RMSE")
            check(abs(plotted - 100 * stats["ate_rmse_m"]) <= 0.0101,
                  f"{name}: the error plot's RMSE {plotted} cm, stats' ATE {100 * stats['ate_rmse_m']:.4f} cm")
        note = re.search(r'<div class="note" id="trajectory-note">(.*?)</div>', dom, re.S)
        check(note and ("y flipped" in note.group(1)) == stats["ate_flip_y"],
              f"{name}: trajectory note {note.group(1) if note else None!r}, flip {stats['ate_flip_y']}")
    else:
        check(rows.get("ATE") == "no ground truth", f"{name}: ATE row {rows.get('ATE')!r} without ground truth")
        check(not any(l.startswith("RPE") for l in rows), f"{name}: an RPE row without ground truth")
    # The block map's memory row (stats.json's map_*); none for the dense cube.
    map_row = rows.get("Map (volume=blocks)")
    if "map_blocks" not in stats:
        check(map_row is None, f"{name}: a map row without a block map: {map_row!r}")
        return
    check(map_row is not None, f"{name}: no map row (rows: {list(rows)})")
    if map_row is None:
        return
    check(number_after(map_row) == stats["map_blocks"], f"{name}: map {map_row!r}, stats {stats['map_blocks']} blocks")
    check(abs(number_after(map_row, "blocks,") - stats["map_bytes"] / 1048576) <= 0.051,
          f"{name}: map {map_row!r}, stats {stats['map_bytes']} bytes")
    check(number_after(map_row, "map_budget_mb") == float(stats["config"]["volume"]["map_budget_mb"]),
          f"{name}: map {map_row!r}, budget {stats['config']['volume']['map_budget_mb']}")
    swapped = re.search(r"(\d+) blocks swapped to host memory \(([0-9.]+) MiB, (\d+) passes\)", map_row)
    if stats["map_blocks_swapped"] > 0:
        check(swapped is not None and int(swapped.group(1)) == stats["map_blocks_swapped"]
              and abs(float(swapped.group(2)) - stats["map_swapped_bytes"] / 1048576) <= 0.051
              and int(swapped.group(3)) == stats["map_swap_passes"],
              f"{name}: map {map_row!r}, stats {stats['map_blocks_swapped']} swapped in {stats['map_swap_passes']} passes")
    else:
        check(swapped is None, f"{name}: map {map_row!r} says blocks were swapped, stats none")
    short = re.search(r"(\d+) frame\(s\) short of blocks, from frame (\d+)", map_row)
    if stats["map_frames_short_of_blocks"] > 0:
        check(short is not None and int(short.group(1)) == stats["map_frames_short_of_blocks"]
              and int(short.group(2)) == stats["map_first_frame_short_of_blocks"],
              f"{name}: map {map_row!r}, stats {stats['map_frames_short_of_blocks']} frames short from "
              f"{stats['map_first_frame_short_of_blocks']}")
    else:
        check("no frame short of blocks" in map_row, f"{name}: map {map_row!r}, stats no frame short")


def read_stats(run):
    with open(os.path.join(run, "stats.json")) as f:
        return json.load(f)


def console_errors(log):
    return [line for line in log.splitlines()
            if "CONSOLE" in line and ("Uncaught" in line or "Error" in line)]


def main():
    kfx = sys.argv[1]
    chromium = find_chromium()
    if not chromium:
        print("SKIP: chromium is not installed (scripts/setup installs Debian's chromium)")
        return SKIP
    if not os.path.exists("/usr/share/javascript/three/three.min.js") and "KFX_THREE_JS_DIR" not in os.environ:
        print("SKIP: three.js is not installed (scripts/setup installs Debian's libjs-three)")
        return SKIP
    failures = []

    def check(condition, message):
        if not condition:
            failures.append(message)
            print("FAIL:", message)

    with tempfile.TemporaryDirectory(prefix="kfx_report_browser_") as tmp:
        run = os.path.join(tmp, "run")
        subprocess.run([kfx, "run", "synthetic:frames=20,width=160,height=120", "--backend", "cpu",
                        "-q", "--renders", "-z", "5", "--no-report", "--out", run], check=True)
        real = os.path.join(tmp, "real_mesh")
        shutil.copytree(run, real)
        subprocess.run([kfx, "report", real], check=True, capture_output=True)
        # A sphere 1.2 m in front of the first camera (which looks down +z), radius 0.4 m.
        camera = first_camera_position(os.path.join(run, "trajectory.txt"))
        write_sphere_ply(os.path.join(run, "mesh.ply"), (camera[0], camera[1], camera[2] + 1.2), 0.4)
        subprocess.run([kfx, "report", run], check=True)
        page = os.path.join(run, "report.html")
        with open(page) as f:
            html = f.read()
        check(re.search(r'<script[^>]+src=', html) is None, "the page loads a script from elsewhere")

        dom, log = load_page(chromium, page, tmp)
        body = body_attributes(dom)
        check(body.get("data-status") == "ok",
              f"page status {body.get('data-status')!r}, errors: {re.search(r'<div id=.errors.>(.*?)</div>', dom, re.S).group(1)[:500]}")
        check(not console_errors(log), f"console errors: {console_errors(log)[:5]}")
        view = int(body.get("data-view-pixels", "0"))
        model = int(body.get("data-mesh-pixels", "-1"))
        # The sphere fills a good part of the view from the start position; a blank canvas is 0.
        check(view > 0 and model > 0.02 * view, f"3D view: {model} model pixels of {view}")
        check(body.get("data-mesh-edge-pixels") == "0",
              f"3D view: the model is cut off ({body.get('data-mesh-edge-pixels')} model pixels on the border)")
        # report.html#model: the run's own mesh (a room around the cameras) alone, framed whole
        # in the window (no model pixel on its border), without scrollbars.
        model_dom, _ = load_page(chromium, os.path.join(real, "report.html") + "#model", tmp)
        model_body = body_attributes(model_dom)
        check(model_body.get("data-status") == "ok", f"#model page status {model_body.get('data-status')!r}")
        check(int(model_body.get("data-mesh-pixels", "0")) > 0.02 * int(model_body.get("data-view-pixels", "0")),
              "#model: the model is not drawn")
        check(model_body.get("data-mesh-edge-pixels") == "0",
              f"#model: the model is cut off ({model_body.get('data-mesh-edge-pixels')} model pixels on the border)")
        check(model_body.get("data-scrollbars") == "false", f"#model: scrollbars ({model_body.get('data-scrollbars')})")
        plots = re.findall(r'<svg class="plot".*?</svg>', dom, re.S)
        check(len(plots) >= 4, f"{len(plots)} plots, expected trajectory top/side, error, stage times")
        # Energy per frame (issue 13): a row per domain, with figures or the reason.
        check(re.search(r"Energy, CPU</td><td>[^<]+", dom) is not None, "no CPU energy row in the summary")
        check(all("<polyline" in p for p in plots), "a plot without a line")
        check(len(re.findall(r'<img alt="(?:depth|track|volume) \d+"', dom)) == 12,
              "expected 12 renders (frames 0, 5, 10, 15)")
        check("The renders of all 4 frame(s) rendered" in dom, "the page does not say it shows every render")
        # The plan view: the two axes along which the ground truth travelled farthest.
        stats = read_stats(run)
        est_stamps = [float(l.split()[0]) for l in open(os.path.join(run, "trajectory.txt"))
                      if l.strip() and not l.startswith("#")]
        gt = [[float(v) for v in l.split()[:4]] for l in open(os.path.join(run, "groundtruth.txt"))
              if l.strip() and not l.startswith("#")]
        gt = [p[1:] for p in gt if est_stamps[0] - 0.02 <= p[0] <= est_stamps[-1] + 0.02]
        extent = [max(p[a] for p in gt) - min(p[a] for p in gt) for a in range(3)]
        far = sorted(range(3), key=lambda a: (-extent[a], a))
        plan = "xyz"[min(far[:2])] + ", " + "xyz"[max(far[:2])]
        check(f"Trajectory, plan view ({plan})" in dom, f"no plan view ({plan}) for extents {extent}")

        # The summary says what stats.json says (a run with ground truth and renders).
        check_summary_against_stats(check, "synthetic run", dom, read_stats(run))

        # A run whose tracking always fails (the accept test wants 99 % inliers), without
        # mesh.ply: the page says the mesh is missing, still works, and marks the lost frames.
        run2 = os.path.join(tmp, "lost")
        subprocess.run([kfx, "run", "synthetic:frames=12,width=160,height=120", "--backend", "cpu",
                        "-q", "--set", "min_inlier_fraction=0.99", "--no-report", "--no-mesh",
                        "--renders", "-z", "1", "--out", run2], check=True)
        subprocess.run([kfx, "report", run2], check=True, capture_output=True)
        dom, log = load_page(chromium, os.path.join(run2, "report.html"), tmp)
        body = body_attributes(dom)
        check(body.get("data-status") == "ok", f"no-mesh page status {body.get('data-status')!r}")
        check(not console_errors(log), f"no-mesh page console errors: {console_errors(log)[:5]}")
        check("No mesh: no mesh.ply" in dom, "the no-mesh page does not say the mesh is missing")
        check(int(body.get("data-mesh-pixels", "-1")) == 0, "the no-mesh page draws a model")
        plots = re.findall(r'<svg class="plot".*?</svg>', dom, re.S)
        check(len(plots) >= 4, "no-mesh page lost its plots")
        # Frames 4..11 ran tracking and failed: 8 red lines in each per-frame plot.
        lost_lines = [len(re.findall(r'class="lost"', p)) for p in plots]
        check(lost_lines.count(8) >= 2, f"lost-frame lines per plot: {lost_lines}, expected 8 in two")
        check("tracking failed" in dom, "the trajectory plots do not mark the failed frames")
        # Renders of 12 frames, 8 shown: the page says so.
        check("Showing the renders of 8 of the 12 frames rendered" in dom,
              "the page does not say it shows 8 of the 12 frames' renders")
        check_summary_against_stats(check, "lost run", dom, read_stats(run2))

        # Three more runs whose summaries must equal their stats.json: intrinsics mirrored in
        # y (the ATE flips y, so must the plots), one bootstrap frame with every tracking
        # failing (frames 1..11 lost, not 4 onwards), and an input without ground truth.
        k = read_stats(run)["intrinsics_input_px"]
        small = "synthetic:frames=12,width=160,height=120"
        cases = {
            "flip": [small, "-k", f"{k[0]},{-k[1]},{k[2]},{k[3]}"],
            "bootstrap1": [small, "--set", "bootstrap_frames=1", "--set", "min_inlier_fraction=0.99"],
        }
        raw = os.path.join(tmp, "nogt.raw")
        subprocess.run([kfx, "convert", small, raw], check=True, capture_output=True)
        with open(raw + ".json") as f:
            sidecar = json.load(f)
        sidecar["ground_truth"] = []
        with open(raw + ".json", "w") as f:
            json.dump(sidecar, f)
        cases["no ground truth"] = [raw]
        # A block map whose 1 MiB budget is full from the first frame: the map row says so.
        cases["blocks, budget full"] = [small, "--set", "volume=blocks", "--set", "map_budget_mb=1"]
        for name, args in cases.items():
            folder = os.path.join(tmp, name.replace(" ", "_"))
            subprocess.run([kfx, "run", *args, "--backend", "cpu", "-q", "--no-mesh", "--out", folder],
                           check=True, capture_output=True)
            stats = read_stats(folder)
            if name == "flip":
                check(stats.get("ate_flip_y") is True, "the mirrored run's ATE did not flip y")
            if name == "blocks, budget full":
                check(stats.get("map_frames_short_of_blocks", 0) > 0,
                      f"the 1 MiB block map had no frame short of blocks: {stats.get('map_frames_short_of_blocks')}")
            if name == "bootstrap1":
                check(stats["lost"] == 11, f"bootstrap_frames=1 run: {stats['lost']} lost, expected 11 (frames 1..11)")
            dom, log = load_page(chromium, os.path.join(folder, "report.html"), tmp)
            check(body_attributes(dom).get("data-status") == "ok", f"{name}: page status not ok")
            check_summary_against_stats(check, name, dom, stats)

    if failures:
        return 1
    print("report.html: no script error, model drawn, plots and renders present")
    return 0


if __name__ == "__main__":
    sys.exit(main())
