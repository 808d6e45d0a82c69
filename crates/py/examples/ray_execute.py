"""The execute experiment (the robot sorting objects of random new scenes) as Ray tasks, one per scene.

    python ray_execute.py                           # a local Ray on this machine's CPUs
    python ray_execute.py --address auto            # the Ray cluster this machine belongs to
    python ray_execute.py --address ray://head:10001 --trials 1000
    python ray_execute.py --backend local           # no Ray: one trial after the other
    python ray_execute.py --compare                 # both, checks they agree and prints the speed-up

The model is learned first from a recorded sorting demonstration (record → infer → learn, ~2 min) unless
`--model model.json` is given. Each trial is a pure function of (config, trial index): the same trial
gives the same result on any worker, so the run is reproducible whatever the cluster does. Workers
need pbd installed (`pip install ./crates/py`, or a wheel from `maturin build --release`); the model is
shipped inline with the tasks, no shared file system is needed.
"""

import argparse
import collections
import os
import time

import pbd
from pbd.experiment import run, strip_timing


def model_path(args):
    if args.model:
        return args.model
    os.makedirs(args.out, exist_ok=True)
    demo = os.path.join(args.out, "sort.mcap")
    print("recording a sorting demonstration (scripted teacher) ...")
    pbd.record(demo, scene="sorting", script="sort", seed=args.seed, progress=True)
    inference = pbd.infer(demo)
    model = pbd.learn([inference], output=os.path.join(args.out, "model.json"))
    print(model.explain())
    return os.path.join(args.out, "model.json")


def summarize(results):
    rows = [r for t in results for r in t["rows"]]
    executed = [r for r in rows if r["decision"] != "ignore"]
    placed = sum(r["placed"] for r in executed)
    failures = collections.Counter(r["failure"] for r in executed if r["failure"])
    correct = sum(r["decision_correct"] for r in rows)
    print(f"{len(results)} scenes, {len(rows)} objects; decisions matching the task {correct}/{len(rows)}; "
          f"placed {placed}/{len(executed)} executed")
    for f, n in failures.most_common():
        print(f"  failure: {f} ×{n}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--address", default=None, help="Ray address (None: start a local Ray; 'auto': join the cluster)")
    p.add_argument("--backend", default="ray", choices=["ray", "local"])
    p.add_argument("--trials", type=int, default=8)
    p.add_argument("--objects", type=int, default=2)
    p.add_argument("--scene", default="sorting-new")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--model", default=None)
    p.add_argument("--out", default="ray-execute")
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray (default: all)")
    p.add_argument("--compare", action="store_true", help="run local and Ray, compare, print the speed-up")
    args = p.parse_args()

    config = {
        "model": model_path(args),
        "scene": args.scene,
        "objects": args.objects,
        "task": {"red": "bin-right", "blue": "bin-left"},
        "seed": args.seed,
    }
    backends = ["local", "ray"] if args.compare else [args.backend]
    results = {}
    for backend in backends:
        if backend == "ray":
            import ray

            ray.init(address=args.address, num_cpus=args.num_cpus if args.address is None else None,
                     include_dashboard=False, log_to_driver=False)
        t = time.perf_counter()
        results[backend] = run(config, args.trials, backend=backend)
        print(f"{backend}: {args.trials} trials in {time.perf_counter() - t:.1f} s wall")
        summarize(results[backend])
    if args.compare:
        same = strip_timing(results["local"]) == strip_timing(results["ray"])
        print("Ray results equal the local results trial by trial:", same)


if __name__ == "__main__":
    main()
