#!/usr/bin/env python3
"""scaling_model.py: the cluster model of docs/scaling.md for data-parallel `hdnet train`.

A step on R ranks = the slowest rank's compute for its share of the global batch + one ring
allreduce of the gradients (HD-Net's and the discriminator's, float32). A ring allreduce moves
2 (R - 1) / R of the buffer through every rank's link in 2 (R - 1) messages, so it costs about
    t_ar = 2 (R - 1) / R * bytes / bandwidth + 2 (R - 1) * latency.
Usage: bench/scaling_model.py [--params N] [--pair-seconds S] [--batch B] [--latency-us L]
The defaults are the paper's configuration (width 48, 256 x 256, batch 8) with the measured
training step of docs/performance.md (1.13 s per pair on one 2-core machine).
"""
import argparse


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", type=int, default=3095600 + 1555585,
                    help="parameters reduced per step (HD-Net + discriminator; width 48)")
    ap.add_argument("--pair-seconds", type=float, default=1.132,
                    help="forward + backward + losses of one pair on one machine (s)")
    ap.add_argument("--batch", type=int, default=8, help="global batch in pairs")
    ap.add_argument("--iters", type=int, default=250000, help="iterations of the run")
    ap.add_argument("--latency-us", type=float, default=20.0, help="per-message latency (us)")
    a = ap.parse_args()
    nbytes = 4 * a.params
    print(f"gradient buffer: {a.params:,} floats = {nbytes / 1e6:.1f} MB per step per rank")
    one = a.batch * a.pair_seconds
    print(f"one machine: {one:.2f} s per iteration, {one * a.iters / 86400:.1f} days for {a.iters:,} iterations")
    print()
    print("| ranks | link | pairs per rank | compute (s) | allreduce (ms) | step (s) | speedup | days for the paper's pairs |")
    print("|---|---|---|---|---|---|---|---|")
    for gbit in (10, 100):
        bw = gbit * 1e9 / 8
        for r in (1, 2, 4, 8, 16, 32, 64):
            per = a.batch / r
            # a rank cannot take less than one pair: beyond B ranks the batch must grow
            pairs = max(per, 1.0)
            compute = pairs * a.pair_seconds
            t_ar = 0.0 if r == 1 else 2 * (r - 1) / r * nbytes / bw + 2 * (r - 1) * a.latency_us * 1e-6
            step = compute + t_ar
            # work per step grows with the batch once r > B: speedup in pairs per second
            speed = (max(a.batch, r) / step) / (a.batch / one)
            note = "" if r <= a.batch else f" (batch {r})"
            # the paper's pairs seen (iters x batch) in fewer, larger iterations beyond B ranks
            days = a.iters * a.batch / max(a.batch, r) * step / 86400
            print(f"| {r} | {gbit} Gbit/s | {pairs:g}{note} | {compute:.2f} | {t_ar * 1e3:.1f} | {step:.2f} | {speed:.1f}x | {days:.2f} |")


if __name__ == "__main__":
    main()
