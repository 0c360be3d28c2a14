#!/usr/bin/env python3
"""Scores a located-alone run (kfx run ... relocalise_each_frame=on) against ground truth
(bench/RESULTS.md, "Localisation in a saved map"; numpy and PIL).
usage: localise_alone_eval.py SEQ_DIR MAP_RUN_DIR ALONE_RUN_DIR FIRST_HALF_N [ATTEMPTS]
SEQ_DIR: the whole sequence (TUM or ICL-NUIM folder); MAP_RUN_DIR: the run that mapped its
first FIRST_HALF_N frames; ALONE_RUN_DIR: the run that located second-half frames alone.
ATTEMPTS (optional): the alone run's stderr with one line per attempt, from a build with a
temporary print ("ATTEMPT frame keyframe perturbation accepted confirmed step_m step_deg
inliers rms misfit" and the pose's 12 numbers, row-major, then "CHOSEN frame index"); with it
the located-pose rule is replayed with other limits and fewer perturbed keyframes.
The map run's tracked poses are aligned to the ground truth (Horn, no scale, on each camera
centre and three points 0.3 m along its axes); that alignment is applied to the alone run's
located poses. A frame "views mapped space" when at least half of its depth points (every 8th
pixel, true pose) fall in 5 cm cells that the first half's depth points reached."""
import sys, os, numpy as np
from PIL import Image

seq, map_dir, alone_dir, n_first = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
icl = os.path.exists(os.path.join(seq, 'associations.txt'))

def quat_to_R(q):
    x, y, z, w = q
    return np.array([[1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w)],
                     [2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w)],
                     [2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y)]])

def read_poses(path):
    out = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = [float(t) for t in line.split()]
        T = np.eye(4); T[:3, :3] = quat_to_R(v[4:8]); T[:3, 3] = v[1:4]
        out.append((v[0], T))
    return out

def read_tracked(run):
    rows = [l.split() for l in open(os.path.join(run, 'slambench.log'))][1:]
    return [int(r[-2]) == 1 for r in rows]

if icl:
    listing = [l.split() for l in open(os.path.join(seq, 'associations.txt')) if l.strip()]
    frames = [(float(r[0]), r[1]) for r in listing]
    gt = read_poses(os.path.join(seq, 'traj0.gt.freiburg'))
    K = (481.2, -480.0, 319.5, 239.5)
else:
    frames = [(float(l.split()[0]), l.split()[1]) for l in open(os.path.join(seq, 'depth.txt'))
              if l.strip() and not l.startswith('#')]
    gt = read_poses(os.path.join(seq, 'groundtruth.txt'))
    K = (517.3, 516.5, 318.6, 255.3)
gt_t = np.array([s for s, _ in gt])

def gt_at(stamp):
    i = int(np.argmin(np.abs(gt_t - stamp)))
    return gt[i][1] if abs(gt_t[i] - stamp) <= 0.02 else None

def pts(T):
    c = T[:3, 3]
    return [c] + [c + 0.3 * T[:3, k] for k in range(3)]

# Alignment from the map run.
mp = read_poses(os.path.join(map_dir, 'trajectory.txt'))
mt = read_tracked(map_dir)
A, B = [], []
for (s, T), ok in zip(mp, mt):
    G = gt_at(s)
    if ok and G is not None:
        A += pts(T); B += pts(G)
A, B = np.array(A), np.array(B)
ma, mb = A.mean(0), B.mean(0)
U, S, Vt = np.linalg.svd((B - mb).T @ (A - ma))
D = np.diag([1, 1, np.sign(np.linalg.det(U @ Vt))])
R = U @ D @ Vt
Talign = np.eye(4); Talign[:3, :3] = R; Talign[:3, 3] = mb - R @ ma

def err(Ta, G):
    d = np.linalg.inv(G) @ Ta
    ang = np.degrees(np.arccos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
    return np.linalg.norm(d[:3, 3]), ang

# Map run's own fit (how good the evaluation frame is).
merr = [err(Talign @ T, gt_at(s)) for (s, T), ok in zip(mp, mt) if ok and gt_at(s) is not None]
me = np.array(merr)

def backproject(path, T, step=8):
    d = np.asarray(Image.open(os.path.join(seq, path)), dtype=np.float64) / 5000.0
    v, u = np.mgrid[0:d.shape[0]:step, 0:d.shape[1]:step]
    z = d[v, u]; m = z > 0
    z, u, v = z[m], u[m], v[m]
    x = (u - K[2]) / K[0] * z; y = (v - K[3]) / K[1] * z
    p = np.stack([x, y, z], 1)
    return p @ T[:3, :3].T + T[:3, 3]

cells = set()
for s, path in frames[:n_first]:
    G = gt_at(s)
    if G is None:
        continue
    for c in map(tuple, np.floor(backproject(path, G) / 0.05).astype(np.int64)):
        cells.add(c)

ap = read_poses(os.path.join(alone_dir, 'trajectory.txt'))
at = read_tracked(alone_dir)
stamp_to_path = {s: p for s, p in frames}
n = views = located_ok = off = located_other = 0
errs = []
for (s, T), ok in zip(ap, at):
    G = gt_at(s)
    if G is None:
        continue
    n += 1
    p = backproject(stamp_to_path[s], G)
    c = np.floor(p / 0.05).astype(np.int64)
    inside = np.mean([tuple(x) in cells for x in c]) if len(c) else 0
    view = inside >= 0.5
    views += view
    if ok:
        e = err(Talign @ T, G)
        good = e[0] <= 0.05 and e[1] <= 5
        if good and view:
            located_ok += 1
        elif good:
            located_other += 1
        if not good:
            off += 1
            print('FURTHER OFF: stamp %s %.1f cm %.2f deg (views mapped: %s)' % (s, e[0]*100, e[1], view))
        if good:
            errs.append(e)
print('map fit: median %.2f cm %.2f deg' % (np.median(me[:, 0])*100, np.median(me[:, 1])))
print('frames %d, view mapped %d, located within 5cm5deg of those %d (%.0f %%), +%d of others, further off %d'
      % (n, views, located_ok, 100.0 * located_ok / max(views, 1), located_other, off))
if errs:
    e = np.array(errs)
    print('located errors: median %.2f cm %.2f deg, max %.2f cm %.2f deg'
          % (np.median(e[:, 0])*100, np.median(e[:, 1]), e[:, 0].max()*100, e[:, 1].max()))

# ---- attempts printed by the run (KFX_PRINT_ATTEMPTS), replayed for fewer perturbed keyframes
if len(sys.argv) > 5:
    att = {}
    for line in open(sys.argv[5]):
        if line.startswith('ATTEMPT'):
            v = line.split()
            f = int(v[1])
            T = np.eye(4); T[:3, :] = np.array([float(x) for x in v[-12:]]).reshape(3, 4)
            att.setdefault(f, []).append(dict(misfit=float(v[10]) if len(v) == 23 else -1, kf=int(v[2]), pert=int(v[3]), acc=int(v[4]), conf=int(v[5]),
                step_m=float(v[6]), step_deg=float(v[7]), inl=float(v[8]), rms=float(v[9]), T=T))
    RULE = dict(inl=0.5, rms=0.01, mis=9.0)
    def qual(a, r=None):
        r = r or RULE
        return a['acc'] and a['conf'] and a['step_m'] <= 0.02 and a['step_deg'] <= 2 and a['rms'] <= r['rms'] and a['inl'] >= r['inl'] and a['misfit'] <= r['mis']
    def choose(atts, r=None):
        q = [a for a in atts if qual(a, r)]
        if not q:
            return None
        best = max(q, key=lambda a: a['inl'])
        for a in q:
            m, d = err(best['T'], a['T'])
            if m > 0.05 or d > 5:
                return None
        return best
    def prefix(atts, P, r=None):
        plain = [a for a in atts if a['pert'] < 0]
        out = list(plain)
        groups = []
        for a in atts:
            if a['pert'] >= 0:
                if a['pert'] == 0:
                    groups.append([])
                groups[-1].append(a)
        for g in groups[:P]:
            if any(qual(a, r) for a in out):
                break
            out += g
        return out
    fidx = {}
    for i, ((s, T), ok) in enumerate(zip(ap, at)):
        fidx[i] = s
    views_of = {}
    for i, s_ in fidx.items():
        G = gt_at(s_)
        if G is None or i not in att:
            continue
        c = np.floor(backproject(stamp_to_path[s_], G) / 0.05).astype(np.int64)
        views_of[i] = (np.mean([tuple(x) in cells for x in c]) >= 0.5) if len(c) else False
    variants = [dict(inl=0.5, rms=0.01, mis=9.0)] + [dict(inl=il, rms=0.01, mis=0.07) for il in (0.5, 0.45, 0.4, 0.3)]
    for r in variants:
        for P in range(0, 3):
            good = off = offv = 0
            for i, v in views_of.items():
                G = gt_at(fidx[i])
                atts = prefix(att[i], P, r)
                b = choose(atts, r)
                if b is None:
                    continue
                e = err(Talign @ b['T'], G)
                if e[0] <= 0.05 and e[1] <= 5:
                    good += v
                else:
                    off += 1
            nv = sum(views_of.values())
            print('rule inl>=%.2f rms<=%.3f misfit<=%.2f perturb=%d: located right %d of %d viewing mapped space (%.0f %%), further off %d of all %d'
                  % (r['inl'], r['rms'], r['mis'], P, good, nv, 100.0 * good / max(nv, 1), off, len(views_of)))
    for P in range(0, 4):
        n = views = good = off = passes = right_any = 0
        for i, s in fidx.items():
            G = gt_at(s)
            if G is None or i not in att:
                continue
            p = backproject(stamp_to_path[s], G)
            c = np.floor(p / 0.05).astype(np.int64)
            view = np.mean([tuple(x) in cells for x in c]) >= 0.5 if len(c) else False
            if not view:
                continue
            views += 1
            atts = prefix(att[i], P)
            passes += len(atts)
            if any(a['acc'] and all(np.array(err(Talign @ a['T'], G)) <= (0.05, 5)) for a in atts):
                right_any += 1
            b = choose(atts)
            if b is None:
                continue
            e = err(Talign @ b['T'], G)
            if e[0] <= 0.05 and e[1] <= 5:
                good += 1
            else:
                off += 1
        print('replay perturb=%d: views %d, located right %d (%.0f %%), further off %d, attempts %d, frames with a right accepted pose %d'
              % (P, views, good, 100.0 * good / max(views, 1), off, passes, right_any))
