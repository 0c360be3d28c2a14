"""What an ATE is made of: per-frame aligned error of kfx runs (or any TUM trajectory) over time.

Usage: scripts/ate_breakdown.py GT.txt RUN [RUN ...] [--flip-y] [--csv OUT.csv]
       (or python -m kfx.study.ate_breakdown ... where the package is installed)

RUN is a `kfx run` output folder (trajectory.txt and slambench.log: tracked flags) or a bare
TUM trajectory file (e.g. ../shared/reference/*.tum.txt; every frame counted as tracked).
For each run it prints:
- the TUM ATE (rigid Horn alignment of positions, as kfx eval) and its split between tracked
  frames and lost frames (pose held), and the error of the frames just after a recovery;
- the squared error by segment of the sequence (tenths), so one bad stretch shows up;
- the ATE the same trajectory would have under three diagnostic ground-truth corrections that no
  tracker controls: a stamp offset between depth and motion capture (best within ±50 ms), a
  constant offset of the motion-capture point from the depth camera's centre (lever arm, fitted
  in the camera frame; --lever-arm applies one fitted elsewhere), both, and a scale of the estimate (Umeyama). A large drop says the error floor lies in the ground truth's
  timing or calibration, not in tracking.
- the correlation of the error with the ground truth's angular speed.
Pure standard library (no numpy), so it runs wherever the tests run.
"""

import argparse
import bisect
import csv
import math
import os
import sys


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            v = [float(x) for x in line.replace(",", " ").split()]
            rows.append((v[0], v[1:4], v[4:8]))
    return rows


def read_tracked(run_dir):
    """Per-frame tracked flag from slambench.log (column 'tracked'), or None."""
    path = os.path.join(run_dir, "slambench.log")
    if not os.path.exists(path):
        return None
    flags = []
    with open(path) as f:
        header = None
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if header is None:
                header = parts
                continue
            flags.append(int(float(parts[header.index("tracked")])))
    return flags


def quat_to_matrix(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def matvec(m, v):
    return [sum(m[r][c] * v[c] for c in range(3)) for r in range(3)]


def mat_t_vec(m, v):
    return [sum(m[c][r] * v[c] for c in range(3)) for r in range(3)]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def norm(a):
    return math.sqrt(sum(x * x for x in a))


def jacobi_top_eigenvector(a):
    """Eigenvector of the largest eigenvalue of a symmetric 4x4 matrix (cyclic Jacobi)."""
    n = 4
    a = [row[:] for row in a]
    v = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for _ in range(100):
        off = sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        if off < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if abs(a[p][q]) < 1e-300:
                    continue
                theta = (a[q][q] - a[p][p]) / (2 * a[p][q])
                t = (1 if theta >= 0 else -1) / (abs(theta) + math.sqrt(theta * theta + 1))
                c = 1 / math.sqrt(t * t + 1)
                s = t * c
                for k in range(n):
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    best = max(range(n), key=lambda i: a[i][i])
    return [v[k][best] for k in range(n)]


def horn(src, dst):
    """Rotation R and translation t minimising sum |R src_i + t - dst_i|^2 (Horn 1987)."""
    m = len(src)
    cs = [sum(p[i] for p in src) / m for i in range(3)]
    cd = [sum(p[i] for p in dst) / m for i in range(3)]
    s = [[0.0] * 3 for _ in range(3)]
    for p, q in zip(src, dst):
        a, b = sub(p, cs), sub(q, cd)
        for i in range(3):
            for j in range(3):
                s[i][j] += a[i] * b[j]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = s
    n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ]
    w, x, y, z = jacobi_top_eigenvector(n)
    r = quat_to_matrix((x, y, z, w))
    t = sub(cd, matvec(r, cs))
    return r, t


def aligned_errors(est, gt):
    r, t = horn(est, gt)
    return [norm(sub(add(matvec(r, p), t), q)) for p, q in zip(est, gt)], (r, t)


def similarity_errors(src, dst):
    """Errors after alignment with rotation, translation and one scale (Umeyama without
    reflection; the rotation is Horn's, which the optimal scale does not change)."""
    r, _ = horn(src, dst)
    m = len(src)
    cs = [sum(p[i] for p in src) / m for i in range(3)]
    cd = [sum(p[i] for p in dst) / m for i in range(3)]
    num = sum(sum(a * b for a, b in zip(matvec(r, sub(p, cs)), sub(q, cd))) for p, q in zip(src, dst))
    den = sum(sum(a * a for a in sub(p, cs)) for p in src)
    scale = num / den
    return [norm(sub(add([scale * x for x in matvec(r, sub(p, cs))], cd), q))
            for p, q in zip(src, dst)], scale


def rms(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else float("nan")


def interpolate_gt(gt, stamps_gt, stamp):
    """Ground-truth position and rotation at `stamp` (positions linear; rotation nearest)."""
    i = bisect.bisect_left(stamps_gt, stamp)
    if i <= 0 or i >= len(gt):
        return None
    (t0, p0, q0), (t1, p1, q1) = gt[i - 1], gt[i]
    if t1 - t0 > 0.05:
        return None
    a = (stamp - t0) / (t1 - t0)
    p = [p0[k] + a * (p1[k] - p0[k]) for k in range(3)]
    return p, quat_to_matrix(q0 if a < 0.5 else q1)


def associate(est, gt, max_dt=0.02):
    """Nearest ground-truth stamp within max_dt for every estimate (kfx eval's rule)."""
    stamps = [g[0] for g in gt]
    pairs = []
    for i, (s, _, _) in enumerate(est):
        j = bisect.bisect_left(stamps, s)
        best = min((k for k in (j - 1, j) if 0 <= k < len(gt)), key=lambda k: abs(stamps[k] - s))
        if abs(stamps[best] - s) < max_dt:
            pairs.append((i, best))
    return pairs


def lever_arm_fit(est_p, gt_p, gt_r, iterations=30):
    """ATE when the ground truth's point sits at a constant offset d (camera frame) from the
    estimate's: alternate Horn alignment and the least-squares d."""
    d = [0.0, 0.0, 0.0]
    errors = None
    for _ in range(iterations):
        target = [add(p, matvec(r, d)) for p, r in zip(gt_p, gt_r)]
        errors, (ra, ta) = aligned_errors(est_p, target)
        residual = [sub(add(matvec(ra, p), ta), g) for p, g in zip(est_p, gt_p)]
        # minimise sum |res_i - R_i d|^2: d = mean(R_i^T res_i) (R_i orthonormal)
        acc = [0.0, 0.0, 0.0]
        for res, r in zip(residual, gt_r):
            acc = add(acc, mat_t_vec(r, res))
        d = [a / len(residual) for a in acc]
    return rms(errors), d


def angular_speed(gt, stamps_gt, stamp, dt=0.03):
    a = interpolate_gt(gt, stamps_gt, stamp - dt / 2)
    b = interpolate_gt(gt, stamps_gt, stamp + dt / 2)
    if a is None or b is None:
        return float("nan")
    ra, rb = a[1], b[1]
    # angle of ra^T rb
    tr = sum(ra[k][i] * rb[k][i] for i in range(3) for k in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2)))) / dt


def correlation(xs, ys):
    pts = [(x, y) for x, y in zip(xs, ys) if not (math.isnan(x) or math.isnan(y))]
    n = len(pts)
    mx = sum(p[0] for p in pts) / n
    my = sum(p[1] for p in pts) / n
    sxy = sum((p[0] - mx) * (p[1] - my) for p in pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    syy = sum((p[1] - my) ** 2 for p in pts)
    return sxy / math.sqrt(sxx * syy) if sxx > 0 and syy > 0 else float("nan")


def analyse(run, gt, flip_y, csv_rows, fixed_arm=None):
    if os.path.isdir(run):
        est = read_tum(os.path.join(run, "trajectory.txt"))
        tracked = read_tracked(run) or [1] * len(est)
    else:
        est = read_tum(run)
        tracked = [1] * len(est)
    if flip_y:
        est = [(s, [p[0], -p[1], p[2]], q) for s, p, q in est]
    stamps_gt = [g[0] for g in gt]
    pairs = associate(est, gt)
    est_p = [est[i][1] for i, _ in pairs]
    gt_p = [gt[j][1] for _, j in pairs]
    gt_r = [quat_to_matrix(gt[j][2]) for _, j in pairs]
    frames = [i for i, _ in pairs]
    errors, _ = aligned_errors(est_p, gt_p)
    ok = [tracked[f] if f < len(tracked) else 1 for f in frames]
    # the bootstrap frames before the first tracked one are untracked by design, not lost
    first = next((f for f, o in zip(frames, ok) if o), 0)
    ok = [1 if f < first else o for f, o in zip(frames, ok)]
    after = set()
    for k in range(1, len(frames)):
        if ok[k] and not ok[k - 1]:
            after.update(range(k, min(k + 5, len(frames))))
    total_sq = sum(e * e for e in errors)
    lost_sq = sum(e * e for e, o in zip(errors, ok) if not o)
    after_sq = sum(errors[k] ** 2 for k in after)
    name = run.rstrip("/").split("/")[-1]
    print(f"\n== {name}: {len(frames)} paired frames, {len(frames) - sum(ok)} lost")
    tracked_rms = rms([e for e, o in zip(errors, ok) if o])
    print(f"ATE {100 * rms(errors):.2f} cm; tracked-only {100 * tracked_rms:.2f} cm;"
          f" share of sum e^2: lost frames {100 * lost_sq / total_sq:.1f} %, 5 frames after each"
          f" recovery {100 * after_sq / total_sq:.1f} %")
    # re-aligned over tracked frames only (the lost frames' held poses out of the fit too)
    ti = [k for k in range(len(frames)) if ok[k]]
    e_t, _ = aligned_errors([est_p[k] for k in ti], [gt_p[k] for k in ti])
    print(f"ATE over tracked frames only, aligned on them: {100 * rms(e_t):.2f} cm")
    tenth = max(1, len(frames) // 10)
    parts = []
    for s in range(0, len(frames), tenth):
        seg = errors[s:s + tenth]
        parts.append(f"{frames[s]}-{frames[min(s + tenth, len(frames)) - 1]}: rms {100 * rms(seg):.2f}"
                     f" ({100 * sum(e * e for e in seg) / total_sq:.0f} %)")
    print("by segment (cm, share of sum e^2):\n  " + "\n  ".join(parts))
    # ground-truth diagnostics
    best = (rms(errors), 0)
    for ms in range(-50, 51, 2):
        shifted = [interpolate_gt(gt, stamps_gt, est[i][0] + ms / 1000.0) for i in frames]
        keep = [k for k, g in enumerate(shifted) if g is not None]
        e, _ = aligned_errors([est_p[k] for k in keep], [shifted[k][0] for k in keep])
        if rms(e) < best[0]:
            best = (rms(e), ms)
    print(f"diagnostic: best stamp offset {best[1]:+d} ms -> ATE {100 * best[0]:.2f} cm")
    lever_rms, d = lever_arm_fit(est_p, gt_p, gt_r)
    print(f"diagnostic: lever arm d = ({100 * d[0]:.2f}, {100 * d[1]:.2f}, {100 * d[2]:.2f}) cm"
          f" (|d| {100 * norm(d):.2f} cm) -> ATE {100 * lever_rms:.2f} cm")
    if fixed_arm:
        e_f, _ = aligned_errors(est_p, [add(p, matvec(r, fixed_arm)) for p, r in zip(gt_p, gt_r)])
        print(f"diagnostic: the given lever arm ({', '.join(f'{100 * x:.2f}' for x in fixed_arm)})"
              f" cm -> ATE {100 * rms(e_f):.2f} cm")
    shifted = [interpolate_gt(gt, stamps_gt, est[i][0] + best[1] / 1000.0) for i in frames]
    keep = [k for k, g in enumerate(shifted) if g is not None]
    both_rms, d2 = lever_arm_fit([est_p[k] for k in keep], [shifted[k][0] for k in keep],
                                 [shifted[k][1] for k in keep])
    print(f"diagnostic: both -> ATE {100 * both_rms:.2f} cm (d = {100 * norm(d2):.2f} cm)")
    e_s, scale = similarity_errors(est_p, gt_p)
    print(f"diagnostic: with a scale {scale:.4f} -> ATE {100 * rms(e_s):.2f} cm")
    speeds = [angular_speed(gt, stamps_gt, est[i][0]) for i in frames]
    known = [w for w in speeds if not math.isnan(w)]
    print(f"correlation of error with angular speed: {correlation(speeds, errors):.2f};"
          f" mean speed {sum(known) / len(known):.0f} deg/s")
    for f, e, o, w in zip(frames, errors, ok, speeds):
        csv_rows.append({"run": name, "frame": f, "error_m": f"{e:.5f}", "tracked": o,
                         "angular_speed_deg_s": f"{w:.1f}"})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("gt")
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--flip-y", action="store_true")
    ap.add_argument("--csv", help="write per-frame errors here")
    ap.add_argument("--lever-arm", help="x,y,z metres: also the ATE with this lever arm (e.g. one"
                    " fitted on another sequence of the same camera: a cross-check)")
    args = ap.parse_args(argv)
    gt = read_tum(args.gt)
    rows = []
    for run in args.runs:
        arm = [float(x) for x in args.lever_arm.split(",")] if args.lever_arm else None
        analyse(run, gt, args.flip_y, rows, arm)
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    sys.exit(main())
