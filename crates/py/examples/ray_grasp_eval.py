"""The grasp evaluation of §6.5 (prototype model against the naive baseline) and the execute experiment,
as Ray tasks: one task per test object / per random scene.

    python ray_grasp_eval.py                        # a local Ray on this machine's CPUs
    python ray_grasp_eval.py --address auto         # the Ray cluster this machine belongs to
    python ray_grasp_eval.py --backend local        # no Ray
    python ray_grasp_eval.py --compare              # local and Ray: same results? how much faster?

Without `--prototypes`, a small corpus is demonstrated and a prototype model learned first (~10 s);
without `--model`, the execute part is skipped unless `--execute` asks to record → infer → learn a
sorting model first (~2 min). Every trial is a pure function of (config, trial index), so the results
are the same on any worker and equal `pbd grasp eval`'s rows object by object. Workers need pbd
installed; models travel inline with the tasks.
"""

import argparse
import os
import time

import pbd
from pbd.experiment import run, strip_timing


def prototypes(args):
    if args.prototypes:
        return args.prototypes
    os.makedirs(args.out, exist_ok=True)
    corpus = os.path.join(args.out, "corpus.json")
    path = os.path.join(args.out, "prototypes.json")
    print(pbd.grasp.record(corpus, objects=["jif", "blue_mug", "red_block", "cola_can", "banana", "tuna_can"],
                           demos=2, seed=args.seed))
    print(pbd.grasp.learn(corpus, path, prototypes=4, burn_in=100, chains=2, seed=args.seed))
    return path


def sorting_model(args):
    if args.model:
        return args.model
    os.makedirs(args.out, exist_ok=True)
    demo = os.path.join(args.out, "sort.mcap")
    pbd.record(demo, scene="sorting", script="sort", seed=args.seed, progress=True)
    pbd.learn([pbd.infer(demo)], output=os.path.join(args.out, "model.json"))
    return os.path.join(args.out, "model.json")


def timed(config, trials, backend, kind):
    t = time.perf_counter()
    results = run(config, trials, backend=backend, kind=kind)
    return results, time.perf_counter() - t


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--address", default=None, help="Ray address (None: a local Ray; 'auto': join the cluster)")
    p.add_argument("--backend", default="ray", choices=["ray", "local"])
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray (default: all)")
    p.add_argument("--test", type=int, default=8, help="grasp test objects (the seed used 12)")
    p.add_argument("--candidates", type=int, default=6)
    p.add_argument("--prototypes", default=None, help="prototype model (pbd grasp learn)")
    p.add_argument("--execute", action="store_true", help="also run the execute experiment")
    p.add_argument("--model", default=None, help="procedural model for --execute (pbd learn)")
    p.add_argument("--scenes", type=int, default=8)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="ray-grasp-eval")
    p.add_argument("--compare", action="store_true")
    args = p.parse_args()

    experiments = [("grasp", {"model": prototypes(args), "test": args.test, "candidates": args.candidates,
                              "seed": args.seed}, None)]
    if args.execute or args.model:
        experiments.append(("execute", {"model": sorting_model(args), "scene": "sorting-new", "objects": 2,
                                        "task": {"red": "bin-right", "blue": "bin-left"}, "seed": args.seed},
                            args.scenes))
    backends = ["local", "ray"] if args.compare else [args.backend]
    if "ray" in backends:
        import ray

        ray.init(address=args.address, num_cpus=args.num_cpus if args.address is None else None,
                 include_dashboard=False, log_to_driver=False)
    for kind, config, trials in experiments:
        results = {}
        for backend in backends:
            results[backend], wall = timed(config, trials, backend, kind)
            print(f"{kind} on {backend}: {len(results[backend])} trials in {wall:.1f} s wall")
            if kind == "grasp":
                model = sum(r["result"]["object"]["model"] for r in results[backend])
                naive = sum(r["result"]["object"]["naive"] for r in results[backend])
                n = args.candidates * len(results[backend])
                print(f"  grasps held: model {model}/{n}, naive baseline {naive}/{n}")
            else:
                rows = [r for t in results[backend] for r in t["rows"]]
                executed = [r for r in rows if r["decision"] != "ignore"]
                print(f"  placed {sum(r['placed'] for r in executed)}/{len(executed)} executed objects")
        if args.compare:
            print(f"  Ray results equal local trial by trial: "
                  f"{strip_timing(results['local']) == strip_timing(results['ray'])}")


if __name__ == "__main__":
    main()
