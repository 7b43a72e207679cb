"""``ArmKinematics``: the arm's kinematics and dynamics with pinocchio.

Built from the very MJCF the simulator compiles (``cell.sim.arm.build_arm().to_xml()``),
so the controller's model and the simulated arm are the same by construction; the
tests check that pinocchio and MuJoCo agree on the TCP pose and Jacobian to 1e-9.
Joint order: shoulder_pan, shoulder_lift, elbow, wrist_1, wrist_2, wrist_3 (radians).
Poses are 4x4 homogeneous transforms in the arm's base frame (metres).
"""

from __future__ import annotations

import os
import tempfile

import numpy as np
import pinocchio as pin

from cell.errors import RobotError
from cell.robot._checks import finite_vector
from cell.sim.arm import build_arm

__all__ = ["ArmKinematics"]


class ArmKinematics:
    """Forward kinematics, Jacobians and inverse dynamics of the arm (pinocchio).

    ``frame`` arguments name a site of the arm: ``"tcp"`` (cup face) or ``"flange"``.
    """

    def __init__(self, *, tool: str = "suction") -> None:
        xml = build_arm(tool=tool).to_xml()
        fd, path = tempfile.mkstemp(suffix=".xml")
        try:
            with os.fdopen(fd, "w") as fh:
                fh.write(xml)
            self.model = pin.buildModelFromMJCF(path)
        finally:
            os.unlink(path)
        self.data = self.model.createData()
        self._dyn_model = self.model.copy()
        self._dyn_model.gravity.linear[:] = 0.0  # the servos already compensate gravity
        self._dyn_data = self._dyn_model.createData()
        self._frames: dict[str, int] = {}

    def _frame(self, name: str) -> int:
        if not isinstance(name, str):
            raise RobotError(f"argument 'frame': expected a frame name (tcp, flange), got {name!r}")
        if name not in self._frames:
            if not self.model.existFrame(name):
                valid = "tcp, flange"
                raise RobotError(f"unknown arm frame {name!r}; valid: {valid}")
            self._frames[name] = self.model.getFrameId(name)
        return self._frames[name]

    def pose(self, q: np.ndarray, frame: str = "tcp") -> np.ndarray:
        """``T_base_frame`` (4x4) at joint angles ``q`` (6,) rad."""
        fid = self._frame(frame)
        pin.forwardKinematics(self.model, self.data, finite_vector("q", q, 6, RobotError))
        pin.updateFramePlacement(self.model, self.data, fid)
        return self.data.oMf[fid].homogeneous.copy()

    def jacobian(self, q: np.ndarray, frame: str = "tcp") -> np.ndarray:
        """Geometric Jacobian (6, 6) of ``frame`` at ``q``: rows (v, w) in base axes,
        linear velocity of the frame's origin (MuJoCo's ``mj_jacSite`` convention)."""
        fid = self._frame(frame)
        q = finite_vector("q", q, 6, RobotError)
        return pin.computeFrameJacobian(
            self.model, self.data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        ).copy()

    def feedforward_torque(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Inverse dynamics without gravity (N m): ``M(q) qdd + C(q, qd) qd``, rotor
        inertia (armature) included, by pinocchio's RNEA (Featherstone, *Rigid Body
        Dynamics Algorithms*, 2008). Gravity is left out: the servos compensate it."""
        return self._feedforward(finite_vector("q", q, 6, RobotError), finite_vector("qd", qd, 6, RobotError),
                                 finite_vector("qdd", qdd, 6, RobotError))

    def _feedforward(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """:meth:`feedforward_torque` of checked (6,) float64 vectors: the servo loop's call,
        once per physics step, without the argument checks (a quarter of its cost)."""
        return pin.rnea(self._dyn_model, self._dyn_data, q, qd, qdd)
