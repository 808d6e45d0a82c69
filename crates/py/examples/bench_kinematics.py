"""Per-call overhead of Chain.fk + Chain.jacobian against Pinocchio's Python bindings on the same URDF.

    python bench_kinematics.py [path/to/wam7.urdf]     (default ../shared/reference/wam7/wam7.urdf)

Needs pbd and `pip install pin` (Pinocchio). Both are timed the way a Python user calls them: pbd
`chain.fk(q)` and `chain.jacobian(q)`; Pinocchio `framesForwardKinematics` + reading `oMf`, and
`computeFrameJacobian(..., LOCAL_WORLD_ALIGNED)`. Both also have their results compared.
"""

import pathlib
import sys
import timeit

import numpy as np

import pbd

here = pathlib.Path(__file__).resolve()
urdf = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else here.parents[3].parent / "shared/reference/wam7/wam7.urdf"
base, tip = "wam/base_link", "wam/wrist_palm_link"
chain = pbd.Robot.from_urdf(urdf).chain(base, tip)
q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
N = 100_000


def per_call(f):
    return min(timeit.repeat(f, number=N, repeat=5)) / N * 1e6


def pbd_fk_jac():
    chain.fk(q)
    chain.jacobian(q)


t_pbd = per_call(pbd_fk_jac)
t_pbd_fused = per_call(lambda: chain.fk_jacobian(q))
print(f"pbd        fk + jacobian      {t_pbd:6.2f} us/call   (fk_jacobian fused: {t_pbd_fused:.2f} us)")

try:
    import pinocchio as pin
except ImportError:
    print("pinocchio not installed (pip install pin): no comparison")
    sys.exit(0)

model = pin.buildModelFromUrdf(str(urdf))
data = model.createData()
fb, ft = model.getFrameId(base), model.getFrameId(tip)
# The chain's q in Pinocchio's order (the WAM has exactly these 7 joints).
qp = q.copy()


def pin_fk_jac():
    pin.framesForwardKinematics(model, data, qp)
    oMb, oMt = data.oMf[fb], data.oMf[ft]
    pose = (oMb.inverse() * oMt).homogeneous
    jac = pin.computeFrameJacobian(model, data, qp, ft, pin.LOCAL_WORLD_ALIGNED)
    return pose, jac


t_pin = per_call(pin_fk_jac)
pose, jac = pin_fk_jac()
rb = data.oMf[fb].rotation
jac_base = np.vstack([rb.T @ jac[:3], rb.T @ jac[3:]])
print(f"pinocchio  fk + jacobian      {t_pin:6.2f} us/call")
print(f"ratio pbd / pinocchio         {t_pbd / t_pin:6.2f}   (fused: {t_pbd_fused / t_pin:.2f})")
print(f"max |pose diff| {np.abs(pose - chain.fk(q)).max():.2e}, max |jacobian diff| {np.abs(jac_base - chain.jacobian(q)).max():.2e}")
