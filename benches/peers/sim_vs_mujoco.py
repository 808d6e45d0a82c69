#!/usr/bin/env python3
"""pbd's simulator against MuJoCo on the same Dexter scene, side by side, in one run.

    python3 -m venv v && v/bin/pip install mujoco numpy
    v/bin/python benches/peers/sim_vs_mujoco.py [--reps 3] [--pin 0] [--json results.json]

What it does:
  1. `scene_bench export DIR` (crates/dexter-sim/examples/scene_bench.rs) builds the built-in `sorting`
     scene in pbd (two WAMs, two BarrettHands, the head, table, two bins, six objects; sleeping OFF),
     parks the robot and writes that world as MJCF (`DexterSim::to_mjcf`: the same bodies, masses,
     inertias, joint frames/axes/limits/damping, primitive colliders, collision filters, gravity
     compensation, PD motor units and mimic couplings) and, for three scenarios, the motor references
     of every control period of a run of pbd's own skills:
       hold     both arms and hands hold the parked posture, 6 objects resting (5 s);
       grasp    the left arm picks `glass_cleaner` and puts it in the left bin;
       transfer a hand-to-hand transfer as pbd's executive does it: the left hand puts the object on a
                hand-off spot, the right hand takes it to the right bin.
  2. Both engines replay the same references from the same state (1 ms steps): MuJoCo through
     `mujoco.rollout` (its C++ loop, single thread, no Python per step), pbd through
     `scene_bench run` (Rust, single thread). Repetitions alternate between the two engines.
  3. Prints steps/s for each (median of the repetitions), the ratio pbd / MuJoCo (> 1: pbd is faster),
     the contact points each engine carries (mean / max, sampled every 10 steps) and where the task's
     object ended in each (a replay that drops the object in one engine is not the same work).

How comparable the two are (an unfair comparison in our favour is worthless):
  * Same: bodies, masses and inertias, joint kinematics, limits and damping, collider primitives and
    which pairs may collide, friction coefficients, gravity compensation, PD gains and effort limits,
    dt = 1 ms, no sleeping, one thread.
  * Different by construction: MuJoCo solves the contacts with its Newton solver (defaults: up to 100
    iterations, tolerance 1e-8, pyramidal cones, soft constraints with default solref/solimp); pbd uses
    Rapier's soft PGS with 2 substeps per step (1 velocity iteration each; the grasp grid of
    `crates/dexter-sim/examples/grasp_grid.rs` holds its quality at 2) and 60 Hz contacts with a
    2 mm skin. MuJoCo combines friction by max, Rapier by average. Rapier damps the objects' spin
    (1 /s); MuJoCo does not. pbd's step also reads the encoders (with noise) after each step.
  * MuJoCo rebuilds its mass matrix at every step. pbd builds each arm's once per step and keeps it
    while the arm has not moved (every joint within 1e-4 rad and 1e-2 rad/s of the state it was
    built at; `SimSettings::mass_matrix_reuse`, vendor/README.md change 9). Both figures are
    printed: "pbd" (the default) and "pbd, matrices rebuilt every step" (`SIM_MM_REUSE=0`).
  * The references were recorded from pbd, so pbd's replay repeats pbd's run; MuJoCo's replay is
    open-loop and may end differently (the contact counts and the object's final position say so).
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

try:
    import mujoco  # noqa: E402
    from mujoco import rollout  # noqa: E402
except ImportError:  # pragma: no cover
    sys.exit("sim_vs_mujoco: needs the `mujoco` Python package (pip install mujoco numpy)")

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCENARIOS = ("hold", "grasp", "transfer")


def scene_bench_binary(path):
    if path:
        return path
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "dexter-sim", "--example", "scene_bench"],
                   cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "release", "examples", "scene_bench")


def controls(m, traj):
    """(steps x nu) ctrl = kp*q_ref + kd*qd_ref, piecewise constant as recorded; resets by step."""
    names = [m.actuator(a).name for a in range(m.nu)]
    index = {n: i for i, n in enumerate(traj["dofs"])}
    missing = [n for n in names if n not in index]
    if missing:
        raise SystemExit(f"actuators without a recorded DOF: {missing}")
    cols = np.array([index[n] for n in names])
    kp, kd = np.array(traj["kp"])[cols], np.array(traj["kd"])[cols]
    steps = traj["steps"]
    U = np.empty((steps, m.nu))
    U[:] = kp * np.array(traj["initial_q_ref"])[cols] + kd * np.array(traj["initial_qd_ref"])[cols]
    start = 0
    for p in traj["periods"]:
        # The references of a period hold for the steps before `until` and after the previous period.
        end = min(p["until"], steps)
        ctrl = kp * np.array(p["q_ref"])[cols] + kd * np.array(p["qd_ref"])[cols]
        if end > start:
            U[start:end] = ctrl
        start = max(start, end)
        last = ctrl
    if traj["periods"] and start < steps:
        U[start:] = last
    return U


def apply_reset(m, d, traj, q):
    """Robot at configuration q (DOF order of the trajectory), mimic joints by their equality, zero velocity."""
    for name, value in zip(traj["dofs"], q):
        j = m.joint(name)
        d.qpos[m.jnt_qposadr[j.id]] = value
        d.qvel[m.jnt_dofadr[j.id]] = 0.0
    for e in range(m.neq):
        if m.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT:
            continue
        j1, j2 = m.eq_obj1id[e], m.eq_obj2id[e]
        c = m.eq_data[e]
        d.qpos[m.jnt_qposadr[j1]] = c[0] + c[1] * d.qpos[m.jnt_qposadr[j2]]
        d.qvel[m.jnt_dofadr[j1]] = 0.0
    mujoco.mj_forward(m, d)


def segments(traj):
    cuts = [r["step"] for r in traj["resets"]] + [traj["steps"]]
    out, start = [], 0
    for k, c in enumerate(cuts):
        out.append((start, c, traj["resets"][k - 1]["q"] if k > 0 else None))
        start = c
    return out


def mujoco_run(m, traj, U, timed=True):
    """One replay; returns (seconds of stepping, data at the end). Rollout per segment between resets."""
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("now").id)
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(m, spec)
    secs = 0.0
    for start, end, reset in segments(traj):
        if reset is not None:
            apply_reset(m, d, traj, reset)
        if end <= start:
            continue
        s0 = np.empty(size)
        mujoco.mj_getState(m, d, s0, spec)
        Uc = np.ascontiguousarray(U[None, start:end, :])
        t0 = time.perf_counter()
        state, _ = rollout.rollout(m, d, s0[None, :], Uc)
        secs += time.perf_counter() - t0
        mujoco.mj_setState(m, d, state[0, -1], spec)
        mujoco.mj_forward(m, d)
    return secs, d


def mujoco_stats(m, traj, U, obj):
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("now").id)
    mujoco.mj_forward(m, d)
    ncon = []
    resets = {r["step"]: r["q"] for r in traj["resets"]}
    for i in range(traj["steps"]):
        if i in resets:
            apply_reset(m, d, traj, resets[i])
        d.ctrl[:] = U[i]
        mujoco.mj_step(m, d)
        if i % 10 == 0:
            ncon.append(d.ncon)
    pos = d.xpos[m.body(obj).id].tolist()
    return dict(contacts_mean=float(np.mean(ncon)), contacts_max=int(np.max(ncon)), object_final=pos)


def pbd_run(binary, scenario, directory, reuse=True):
    env = dict(os.environ)
    if not reuse:
        env["SIM_MM_REUSE"] = "0"
    out = subprocess.run([binary, "run", scenario, directory, "1"], check=True, capture_output=True, text=True,
                         env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=3, help="repetitions per engine and scenario (alternating)")
    ap.add_argument("--scenarios", default=",".join(SCENARIOS))
    ap.add_argument("--dir", default=None, help="where the MJCF and the trajectories go (default: a temp dir)")
    ap.add_argument("--scene-bench", default=None, help="path of the scene_bench binary (default: cargo build)")
    ap.add_argument("--pin", type=int, default=None, help="pin this process and pbd to this CPU")
    ap.add_argument("--json", default=None, help="write the results here")
    args = ap.parse_args()
    if args.pin is not None:
        os.sched_setaffinity(0, {args.pin})  # inherited by the pbd subprocesses
    binary = scene_bench_binary(args.scene_bench)
    directory = args.dir or tempfile.mkdtemp(prefix="pbd-sim-vs-mujoco-")
    subprocess.run([binary, "export", directory], check=True)
    m = mujoco.MjModel.from_xml_path(os.path.join(directory, "dexter.xml"))
    m.opt.timestep = 0.001
    print(f"mujoco {mujoco.__version__}, python {platform.python_version()}, {platform.machine()}, "
          f"nq {m.nq} nv {m.nv} nu {m.nu} neq {m.neq} ngeom {m.ngeom}; files in {directory}")
    results = {"mujoco_version": mujoco.__version__, "reps": args.reps, "scenarios": {}}
    rows = []
    for scenario in args.scenarios.split(","):
        with open(os.path.join(directory, f"{scenario}.json")) as f:
            traj = json.load(f)
        U = controls(m, traj)
        mujoco_run(m, traj, U[: min(2000, traj["steps"])] if not traj["resets"] else U)  # warm-up
        mj, pb, pb_rebuild, pbd_last = [], [], [], None
        for _ in range(args.reps):
            secs, _ = mujoco_run(m, traj, U)
            mj.append(traj["steps"] / secs)
            pbd_last = pbd_run(binary, scenario, directory)
            pb.append(pbd_last["steps_per_s"])
            pb_rebuild.append(pbd_run(binary, scenario, directory, reuse=False)["steps_per_s"])
        stats = mujoco_stats(m, traj, U, traj["object"])
        r = dict(steps=traj["steps"], mujoco_steps_per_s=mj, pbd_steps_per_s=pb,
                 pbd_rebuild_steps_per_s=pb_rebuild,
                 ratio_pbd_over_mujoco=statistics.median(pb) / statistics.median(mj),
                 ratio_pbd_rebuild_over_mujoco=statistics.median(pb_rebuild) / statistics.median(mj),
                 mujoco=stats, pbd=dict(contacts_mean=pbd_last["contacts_mean"],
                                        contacts_max=pbd_last["contacts_max"],
                                        object_final=pbd_last["object_final"]),
                 recorded_outcome=traj["recorded_outcome"])
        results["scenarios"][scenario] = r
        rows.append((scenario, r))
    print()
    print("| scenario | steps | MuJoCo steps/s | pbd steps/s | pbd / MuJoCo | pbd, matrices rebuilt every step "
          "| that / MuJoCo | contacts MuJoCo (mean/max) "
          "| contacts pbd (mean/max) | object end, MuJoCo | object end, pbd |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for s, r in rows:
        f = lambda p: "(" + ", ".join(f"{x:.3f}" for x in p) + ")"  # noqa: E731
        print(f"| {s} | {r['steps']} | {statistics.median(r['mujoco_steps_per_s']):,.0f} "
              f"| {statistics.median(r['pbd_steps_per_s']):,.0f} | {r['ratio_pbd_over_mujoco']:.2f} "
              f"| {statistics.median(r['pbd_rebuild_steps_per_s']):,.0f} | {r['ratio_pbd_rebuild_over_mujoco']:.2f} "
              f"| {r['mujoco']['contacts_mean']:.1f} / {r['mujoco']['contacts_max']} "
              f"| {r['pbd']['contacts_mean']:.1f} / {r['pbd']['contacts_max']} "
              f"| {f(r['mujoco']['object_final'])} | {f(r['pbd']['object_final'])} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
