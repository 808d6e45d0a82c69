#!/usr/bin/env python3
"""hmmlearn's compiled forward passes on the models of pbd's `cargo bench -p bayes --bench hmm`.

    python hmm_peer.py [--T 100000] [--reps 5] [--kind dense|left_to_right] [--mode scaling|log]

Times hmmlearn 0.3.x `_hmmc.forward_scaling` (implementation="scaling") and `_hmmc.forward_log`
(implementation="log") — the bare compiled forward recursions, without `score()`'s Python wrapper —
on a precomputed emission lattice (T x N), N = 16, with the same two model shapes as pbd's bench:
dense (every transition non-zero) and left-to-right (stay or advance by one or two states, start in
state 0, absorbing last state). Lattice entries are uniform in (0, 1], as in pbd's bench (the work
per step does not depend on the values). Prints one JSON line per case: median obs-steps/s over
--reps runs (T / seconds). Single thread (BLAS/OpenMP pinned to 1).
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import hmmlearn  # noqa: E402
from hmmlearn import _hmmc  # noqa: E402

N = 16


def model(kind, rng):
    if kind == "dense":
        start = rng.uniform(1e-12, 1.0, N)
        trans = rng.uniform(1e-12, 1.0, (N, N))
    else:
        start = np.zeros(N)
        start[0] = 1.0
        trans = np.zeros((N, N))
        for i in range(N):
            for j in range(i, min(i + 3, N)):
                trans[i, j] = rng.uniform(1e-12, 1.0)
    start /= start.sum()
    trans /= trans.sum(axis=1, keepdims=True)
    return start, trans


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--T", type=int, default=100_000)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--seed", type=int, default=20110201)
    ap.add_argument("--kind", action="append", choices=["dense", "left_to_right"])
    ap.add_argument("--mode", action="append", choices=["scaling", "log"])
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    lattice = rng.uniform(1e-12, 1.0, (args.T, N))
    log_lattice = np.log(lattice)
    for kind in args.kind or ["dense", "left_to_right"]:
        start, trans = model(kind, np.random.default_rng(args.seed + len(kind)))
        for mode in args.mode or ["scaling", "log"]:
            if mode == "scaling":
                fn = lambda: _hmmc.forward_scaling(start, trans, lattice)  # noqa: E731
            else:
                with np.errstate(divide="ignore"):
                    ls, lt = np.log(start), np.log(trans)
                fn = lambda: _hmmc.forward_log(ls, lt, log_lattice)  # noqa: E731
            fn()  # warm-up
            times = []
            for _ in range(args.reps):
                t0 = time.perf_counter()
                fn()
                times.append(time.perf_counter() - t0)
            med = statistics.median(times)
            print(json.dumps({"peer": f"hmmlearn {hmmlearn.__version__} {mode}", "kind": kind, "N": N,
                              "T": args.T, "obs_steps_per_s": args.T / med, "seconds": times}), flush=True)


if __name__ == "__main__":
    main()
