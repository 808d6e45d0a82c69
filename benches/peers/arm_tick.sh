#!/usr/bin/env bash
# Arm tick side by side: Pinocchio (C++ and Python) next to pbd's criterion benches, on this machine.
#
#   benches/peers/arm_tick.sh            # 3 rounds (ROUNDS=5 benches/peers/arm_tick.sh for more)
#
# What is timed (same work on both sides, WAM 7-DOF, configurations uniform within the joint limits,
# a new one every call, made before timing):
#   Pinocchio C++  fk_plus_frame_jacobian  forwardKinematics + computeFrameJacobian(tip, LOCAL_WORLD_ALIGNED)
#                  dls_step_eigen          Jᵀ (J Jᵀ + λ² I)⁻¹ e, J 6×7, fixed-size 6×6 LDLT, λ = 0.05
#                  (../shared/reference/peers/bench_pinocchio_cpp.cpp, built three ways by
#                  build_pinocchio_cpp.sh: inline, inline_native = -march=native, lib)
#   Pinocchio Py   the same two through the Python bindings and numpy (bench_pinocchio.py)
#   pbd            control_tick criterion cases (crates/control-basis/benches/control_tick.rs):
#                  fk_jacobian_wam, wam_fk_jacobian_dls_distinct_q, wam_dls_only_distinct_j,
#                  wam_tick_reach_manipulability_distinct_q, arm_tick_reach_with_manipulability_nullspace
# The peer's "FK + J + DLS" is the sum fk_plus_frame_jacobian + dls_step_eigen (it has no fused case).
# Runs are interleaved (C++ peer, pbd, Python peer; ROUNDS times), pinned to core 0 with taskset when it
# exists; each figure is the median over rounds of the per-run median (criterion: the median of its
# samples, from target/criterion/<case>/new/estimates.json).
#
# Needs: ../shared/reference (beside the repository), python3 with venv, pip access to `pin`
# (+ `cmeel-eigen`, `cmeel-urdfdom-headers` for the C++ build), g++, cargo. The venv is made once under
# target/peers-venv and reused; scratch copies of the peer scripts go to target/peers/ (shared/ is
# read-only). The C++ peer is skipped, with a message, when the pin headers cannot be installed.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
SHARED="$(cd "$ROOT/.." && pwd)/shared/reference"
if [ ! -d "$SHARED/peers" ] || [ ! -f "$SHARED/wam7/wam7.urdf" ]; then
  echo "arm_tick.sh: $SHARED (../shared/reference beside the repository, with peers/ and wam7/) is absent;" >&2
  echo "  it holds the Pinocchio peer scripts and the WAM URDF this comparison needs." >&2
  exit 1
fi
ROUNDS="${ROUNDS:-3}"
[ "$ROUNDS" -ge 3 ] || { echo "arm_tick.sh: ROUNDS must be at least 3" >&2; exit 1; }
PIN=()
if command -v taskset >/dev/null 2>&1; then PIN=(taskset -c 0); else echo "(taskset not found: runs are not pinned)"; fi
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"
VENV="$ROOT/target/peers-venv"
WORK="$ROOT/target/peers/work"
OUT="$ROOT/target/peers/results"
mkdir -p "$ROOT/target/peers" "$OUT"
rm -f "$OUT"/*.txt

# --- Python venv with pin (reused) ------------------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
  echo "+ python3 -m venv $VENV"
  python3 -m venv "$VENV"
fi
PY="$VENV/bin/python"
if ! "$PY" -c "import pinocchio" 2>/dev/null; then
  echo "+ pip install pin"
  "$PY" -m pip install --quiet pin
fi
HAVE_CPP=1
if ! "$PY" -c "import cmeel" 2>/dev/null || [ ! -d "$("$PY" -m cmeel cmake 2>/dev/null | tail -1)/include/eigen3" ]; then
  echo "+ pip install cmeel-eigen cmeel-urdfdom-headers"
  "$PY" -m pip install --quiet cmeel-eigen cmeel-urdfdom-headers || HAVE_CPP=0
fi
PREFIX="$("$PY" -m cmeel cmake 2>/dev/null | tail -1 || true)"
if [ "$HAVE_CPP" = 1 ] && { [ ! -d "$PREFIX/include/pinocchio" ] || [ ! -d "$PREFIX/include/eigen3" ]; }; then
  HAVE_CPP=0
fi
[ "$HAVE_CPP" = 1 ] || echo "SKIP Pinocchio C++: pin's headers (or cmeel-eigen) are not installed under '$PREFIX'"

# --- scratch copy of the peer scripts: their ../shared/reference/wam7 paths resolve to $SHARED --------
mkdir -p "$WORK/peers"
ln -sfn "$(cd "$SHARED/.." && pwd)" "$WORK/shared"
for f in bench_pinocchio.py bench_pinocchio_cpp.cpp build_pinocchio_cpp.sh; do
  cp -f "$SHARED/peers/$f" "$WORK/peers/$f"
  chmod u+w "$WORK/peers/$f"
done
URDF="$WORK/shared/reference/wam7/wam7.urdf"
CPP_N="${CPP_N:-200000}"
if [ "$HAVE_CPP" = 1 ]; then
  BIN="$WORK/peers/build/bench_pinocchio_cpp_inline_native"
  if [ ! -x "$BIN" ] || [ "$SHARED/peers/bench_pinocchio_cpp.cpp" -nt "$BIN" ]; then
    echo "+ build_pinocchio_cpp.sh (three builds of the C++ peer; a few minutes)"
    (cd "$WORK/peers" && PYTHON="$PY" ./build_pinocchio_cpp.sh 1000 1 >"$OUT/cpp_build.log" 2>&1) || {
      echo "SKIP Pinocchio C++: build failed (see $OUT/cpp_build.log)"; HAVE_CPP=0; }
  fi
fi

# --- pbd bench binary ---------------------------------------------------------------------------------
echo "+ cargo bench -p control-basis --bench control_tick --no-run"
PBD_BIN="$(cd "$ROOT" && cargo bench -p control-basis --bench control_tick --no-run --message-format=json 2>/dev/null \
  | "$PY" -c 'import json,sys
for l in sys.stdin:
    try: m = json.loads(l)
    except ValueError: continue
    if m.get("reason") == "compiler-artifact" and m.get("target", {}).get("name") == "control_tick" and m.get("executable"):
        print(m["executable"])' | tail -1)"
[ -x "$PBD_BIN" ] || { echo "arm_tick.sh: could not build the control_tick bench" >&2; exit 1; }
PBD_CASES=(fk_jacobian_wam wam_fk_jacobian_dls_distinct_q wam_dls_only_distinct_j
  wam_tick_reach_manipulability_distinct_q arm_tick_reach_with_manipulability_nullspace)

# --- interleaved rounds ---------------------------------------------------------------------------------
for r in $(seq 1 "$ROUNDS"); do
  echo "round $r/$ROUNDS"
  if [ "$HAVE_CPP" = 1 ]; then
    for b in inline inline_native lib; do
      "${PIN[@]}" "$WORK/peers/build/bench_pinocchio_cpp_$b" "$URDF" "$CPP_N" 5 \
        | awk -v b="$b" '/RESULT/ {print "cpp_" b "/" $1, $3}' >>"$OUT/peer.txt"
    done
  fi
  (cd "$ROOT" && "${PIN[@]}" "$PBD_BIN" --bench --warm-up-time 1 --measurement-time 3 \
    "^(fk_jacobian_wam|wam_fk_jacobian_dls_distinct_q|wam_dls_only_distinct_j|wam_tick_reach_manipulability_distinct_q|arm_tick_reach_with_manipulability_nullspace)\$" \
    >"$OUT/pbd_round$r.log" 2>&1)
  for c in "${PBD_CASES[@]}"; do
    "$PY" -c 'import json,sys; print(sys.argv[2], json.load(open(sys.argv[1]))["median"]["point_estimate"] / 1e3)' \
      "$TARGET/criterion/$c/new/estimates.json" "$c" >>"$OUT/pbd.txt"
  done
  (cd "$WORK/peers" && "${PIN[@]}" "$PY" bench_pinocchio.py --n 20000 --reps 5) \
    | awk '$1 ~ /^(fk_plus_frame_jacobian|dls_step_numpy|fk_pose)$/ {print "py/" $1, $3}' >>"$OUT/peer.txt"
done

# --- table ------------------------------------------------------------------------------------------------
"$PY" - "$OUT" "$HAVE_CPP" <<'PYEOF'
import statistics, sys, collections
out, have_cpp = sys.argv[1], sys.argv[2] == "1"
def load(name):
    d = collections.defaultdict(list)
    try:
        for line in open(f"{out}/{name}"):
            k, v = line.split()
            d[k].append(float(v))
    except FileNotFoundError:
        pass
    return {k: statistics.median(v) for k, v in d.items()}
peer, pbd = load("peer.txt"), load("pbd.txt")
rows = []
print(f"\n{'what':58s} {'µs':>8s}")
for k in sorted(peer):
    print(f"peer {k:53s} {peer[k]:8.3f}")
for k in sorted(pbd):
    print(f"pbd  {k:53s} {pbd[k]:8.3f}")
fkj, tick, dls = pbd.get("fk_jacobian_wam"), pbd.get("wam_fk_jacobian_dls_distinct_q"), pbd.get("wam_dls_only_distinct_j")
print(f"\n{'comparison':52s} {'peer µs':>8s} {'pbd µs':>8s} {'pbd/peer':>9s}")
def row(what, p, b):
    if p and b:
        print(f"{what:52s} {p:8.3f} {b:8.3f} {b / p:8.2f}x")
for b in (["inline", "inline_native", "lib"] if have_cpp else []):
    f, d = peer.get(f"cpp_{b}/fk_plus_frame_jacobian"), peer.get(f"cpp_{b}/dls_step_eigen")
    row(f"FK + J              vs Pinocchio C++ ({b})", f, fkj)
    row(f"DLS step            vs Eigen 6x6 LDLT ({b})", d, dls)
    row(f"FK + J + DLS        vs Pinocchio C++ + Eigen ({b})", f + d if f and d else None, tick)
f, d = peer.get("py/fk_plus_frame_jacobian"), peer.get("py/dls_step_numpy")
row("FK + J + DLS        vs Pinocchio Python + numpy", f + d if f and d else None, tick)
m = pbd.get("wam_tick_reach_manipulability_distinct_q")
if m:
    print(f"{'reach ◁ manipulability tick (distinct q)':52s} {'':8s} {m:8.3f}   target ≤ 1.5 µs")
PYEOF
