"""Soak benchmark: one long `kfx run` over the synthetic room, sampling the process's host
memory (VmRSS), the GPU memory it holds (nvidia-smi, CUDA only) and the per-frame computation
time (slambench.log), then saying whether memory stays flat and per-frame time does not drift.

  scripts/soak [--backend cpu|cuda] [--frames N] [--kfx PATH] [--out DIR] [-- extra run options]
  (or python -m kfx.study.soak ... where the package is installed)

Defaults: cuda 10,000 frames, cpu 2,000 frames, 640x480 (compute 320x240), 256^3 volume.
Flat: after the first 10 % of the run, memory grows by at most 2 % (and at most 16 MiB).
No drift: the median per-frame time of the last 10 % of frames is within 10 % of the median
of the 10 % after warm-up. Exits 1 when either fails. Prints one summary block for RESULTS.md.
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

from . import default_path


def rss_mib(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def gpu_mib(pid):
    try:
        out = subprocess.run(
            ["nvidia-smi", "--query-compute-apps=pid,used_memory", "--format=csv,noheader,nounits"],
            capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.TimeoutExpired):
        return None
    for line in out.splitlines():
        parts = [p.strip() for p in line.split(",")]
        if len(parts) == 2 and parts[0] == str(pid):
            return float(parts[1])
    return None


def flat(samples, label):
    """(ok, text) for memory samples [(t, MiB)] after the first 10 % of the run."""
    values = [v for _, v in samples if v is not None]
    if len(values) < 4:
        return True, f"{label}: too few samples ({len(values)}) to judge"
    start = values[len(values) // 10:]
    base, peak, last = start[0], max(start), start[-1]
    growth = peak - base
    ok = growth <= max(16.0, 0.02 * base)
    return ok, (f"{label}: {base:.1f} MiB after warm-up, peak {peak:.1f}, last {last:.1f} "
                f"(growth {growth:+.1f} MiB) -> {'flat' if ok else 'NOT flat'}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="cuda", choices=["cpu", "cuda"])
    parser.add_argument("--frames", type=int, default=0)
    parser.add_argument("--kfx", default=default_path("build", "release", "kfx"))
    parser.add_argument("--out", default=default_path("out", "soak"))
    parser.add_argument("--interval", type=float, default=1.0, help="seconds between samples")
    parser.add_argument("extra", nargs="*", help="more kfx run options (after --)")
    args = parser.parse_args(argv)
    frames = args.frames or (10000 if args.backend == "cuda" else 2000)
    out = os.path.join(args.out, args.backend)
    command = [args.kfx, "run", f"synthetic:frames={frames}", "--backend", args.backend,
               "--out", out, "-q"] + args.extra
    print("scripts/soak:", " ".join(command), flush=True)
    start = time.time()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    host, gpu = [], []
    while process.poll() is None:
        now = time.time() - start
        host.append((now, rss_mib(process.pid)))
        if args.backend == "cuda":
            gpu.append((now, gpu_mib(process.pid)))
        time.sleep(args.interval)
    output = process.stdout.read()
    wall = time.time() - start
    if process.returncode != 0:
        print(output)
        print(f"scripts/soak: kfx run failed (exit {process.returncode})")
        return 1

    times_ms = []
    with open(os.path.join(out, "slambench.log")) as log:
        next(log)
        for line in log:
            fields = line.split()
            times_ms.append(float(fields[7]) * 1000.0)  # computation, seconds
    n = len(times_ms)
    tenth = max(1, n // 10)
    warm = min(30, n // 10)
    early = statistics.median(times_ms[warm:warm + tenth])
    late = statistics.median(times_ms[-tenth:])
    drift = (late - early) / early if early > 0 else 0.0
    drift_ok = abs(drift) <= 0.10

    host_ok, host_text = flat(host, "host RSS")
    lines = [f"frames {n}, wall {wall:.0f} s, backend {args.backend}",
             f"per-frame computation: median {early:.3f} ms (frames {warm}..{warm + tenth - 1}) -> "
             f"{late:.3f} ms (last {tenth}), drift {100 * drift:+.1f} % -> "
             f"{'no drift' if drift_ok else 'DRIFT'}",
             host_text]
    ok = drift_ok and host_ok
    if args.backend == "cuda":
        gpu_ok, gpu_text = flat(gpu, "GPU memory (nvidia-smi)")
        lines.append(gpu_text)
        ok = ok and gpu_ok
    lines.append(output.strip().splitlines()[-2] if output.strip() else "")
    print("\n".join("scripts/soak: " + l for l in lines))
    print("scripts/soak: " + ("PASS: flat memory, no drift" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
