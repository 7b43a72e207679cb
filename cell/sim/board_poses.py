"""Joint configurations that show the flange board to the overhead camera, for the
eye-to-hand calibration (AX = ZB wants the board seen at many tilts about many axes).

``propose_flange_board_poses`` samples board poses under the overhead camera with a
seeded ``np.random.Generator``: a depth along the optical axis, an offset in the view, a
turn about the board's normal and a tilt about a random horizontal axis; solves each by
IK (``ArmIK``'s mink tasks and joint limits, with a full 6-D target on the TCP:
``ArmIK.solve`` only knows tool-down targets) from ``READY``, so every pose is on the
same arm branch (elbow up, as HOME); and keeps the poses that

- collide with nothing (``ArmIK.collides`` for the arm's links, and the same check for
  the plate and its bracket against the furniture and the arm's upstream links),
- show the whole pattern with half a square of white around it inside the image (the
  plate's margin may leave the view: corners near the image's edges are what pins the
  lens distortion down), facing the camera within ``max_view_angle``, unoccluded (rays
  from the camera to every square, inner corner and the outline hit the board first),
- and are joined without a collision to the previous kept pose and to ``start`` (HOME
  by default) by straight joint-space lines: the paths the controller's joint-space
  segments take.

It plans from the cell's CAD (``cell.sim.layout``: where the overhead camera is
mounted) and the lens's nominal field of view, as a user planning the capture would;
nothing here reads the simulator's true camera model, so a calibration that moves
through these poses still learns the camera from images and joint readings alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mink
import mujoco
import numpy as np

from cell.errors import IKError, SimError
from cell.robot.ik import ArmIK
from cell.sim import flange_board, layout
from cell.sim.arm import HOME, JOINT_NAMES, TOOL_LENGTH, add_arm
from cell.sim.conveyor import add_conveyor
from cell.sim.fixtures import add_bins, add_table

__all__ = [
    "READY",
    "BoardPoseSampler",
    "nominal_overhead_camera",
    "propose_flange_board_poses",
]

_PREFIX = "arm/"
# The board flat and face up under the overhead camera, its centre 0.25 m below it at
# (0, 0.45, 0.23) m, its x along world -x: the tool level and pointing away from the
# base (+y), the plate on top, the elbow up as at HOME, the wrist over the tool (IK; of
# the arm's eight solutions the one with the most room over the belt, 34 mm; the tests
# check the pose).
READY = np.array([-2.05678, -1.50426, 2.46685, -0.96259, 1.0848, -1.5708])
_FACE = np.diag([-1.0, 1.0, -1.0, 1.0])  # T_board_face: the plate body's frame
_FLAT = np.diag([-1.0, 1.0, -1.0])  # R_world_board of READY: the face up, x along -x
_UPSTREAM = ("base_link", "shoulder_housing", "shoulder_lift_housing", "upper_arm",
             "elbow_housing", "forearm", "wrist_1_housing", "wrist_2_housing")


def nominal_overhead_camera(fovy: float, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The overhead camera as the cell's drawings give it: (K (3x3), T_world_camera
    (4x4), OpenCV axes) from ``layout`` and the lens's vertical field of view (deg)."""
    f = 0.5 * height / math.tan(math.radians(fovy) / 2)
    K = np.array([[f, 0.0, (width - 1) / 2], [0.0, f, (height - 1) / 2], [0.0, 0.0, 1.0]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # looking straight down, image x = world x
    T[:3, 3] = layout.PICK_ZONE + np.array([0.0, 0.0, layout.OVERHEAD_CAMERA_HEIGHT])
    return K, T


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _model() -> mujoco.MjModel:
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    add_table(spec)
    add_conveyor(spec)
    add_bins(spec)
    add_arm(spec, flange_board=True)
    return spec.compile()


@dataclass
class BoardPoseSampler:
    """The sampler behind ``propose_flange_board_poses`` (its arguments are fields here).

    ``fovy`` (deg), ``width``, ``height`` (px): the overhead camera's nominal lens and
    image; ``depth`` (m): range of the board centre's distance from the camera along its
    axis; ``spread``: the board centre's offset in the view, as a fraction of the room the
    pattern has to move in at that depth and turn, seen flat; ``tilt`` (deg): range of
    the board's tilt from facing straight up, about a horizontal axis drawn uniformly;
    ``turn`` (deg): range of the turn about the normal (0: as at ``READY``);
    ``max_view_angle`` (deg): largest angle between the board's normal and the ray to
    the camera; ``quiet`` (squares): the white around the pattern that must be in view
    (the plate's margin is one square); ``margin`` (px): that outline stays this far
    inside the image; ``clearance`` (m): the least distance from the arm and plate to
    the furniture (and from the plate to the arm's other links);
    ``path_step`` (rad): the joint-space path between poses is checked every such step;
    ``target_tolerance`` (m, and 10x that in rad): how near the IK must come to a drawn
    board pose; ``ik_iterations``: the IK's iterations before it gives a pose up.
    """

    fovy: float = 40.0
    width: int = 640
    height: int = 480
    depth: tuple[float, float] = (0.19, 0.29)
    spread: float = 1.0
    tilt: tuple[float, float] = (12.0, 45.0)
    turn: tuple[float, float] = (-60.0, 60.0)
    max_view_angle: float = 55.0
    margin: float = 4.0
    quiet: float = 0.5
    clearance: float = 0.01
    path_step: float = math.radians(2.0)
    target_tolerance: float = 0.002
    ik_iterations: int = 100
    ik: ArmIK | None = None
    rejected: dict[str, int] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        self.ik = self.ik or ArmIK()
        self.K, self.T_world_camera = nominal_overhead_camera(self.fovy, self.width, self.height)
        self.model = _model()
        self.data = mujoco.MjData(self.model)
        m = self.model
        body = m.body(_PREFIX + flange_board.BODY).id
        self._board_body = body
        self._plate = [g for g in range(m.ngeom)
                       if m.geom_bodyid[g] == body and m.geom_contype[g]]
        arm_root = m.body(_PREFIX + "base").id
        in_arm = {b for b in range(m.nbody) if self._under(b, arm_root)}
        self._furniture = [g for g in range(m.ngeom) if m.geom_bodyid[g] not in in_arm
                           and m.geom_contype[g]]
        self._upstream = [m.geom(_PREFIX + g).id for g in _UPSTREAM]
        T_tcp = np.eye(4)
        T_tcp[2, 3] = TOOL_LENGTH
        self._T_board_tcp = np.linalg.inv(flange_board.T_flange_board()) @ T_tcp
        self._outline, self._ray_points = self._plate_points()
        self._limits = [lim for lim in self.ik.limits
                        if not isinstance(lim, mink.CollisionAvoidanceLimit)]

    def _under(self, b: int, root: int) -> bool:
        while b not in (root, 0):
            b = int(self.model.body_parentid[b])
        return b == root

    def _plate_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Points on the board face (board frame): the outline of the squares' region
        widened by ``quiet`` squares (the white a detector needs around the pattern), and
        every square's centre and inner corner, for the view and occlusion checks."""
        nx, ny = flange_board.INNER_CORNERS
        s = flange_board.SQUARE
        hx, hy = ((nx + 1) / 2 + self.quiet) * s, ((ny + 1) / 2 + self.quiet) * s
        outline = np.array([(sx * hx, sy * hy, 0.0) for sx in (-1, 1) for sy in (-1, 1)])
        centres = [((i - nx / 2) * s, (j - ny / 2) * s, 0.0)
                   for i in range(nx + 1) for j in range(ny + 1)]
        rays = np.vstack([outline, centres, flange_board.board_corners()])
        return outline, rays

    # --- checks -----------------------------------------------------------------------
    def _face_pose(self, q: np.ndarray) -> np.ndarray:
        """The plate body's pose at ``q`` (this sampler's CAD model): its frame is on the
        board's corner plane with z out of the face (the board frame turned about y)."""
        d = self.data
        d.qpos[:] = q
        mujoco.mj_kinematics(self.model, d)
        T = np.eye(4)
        T[:3, :3] = d.xmat[self._board_body].reshape(3, 3)
        T[:3, 3] = d.xpos[self._board_body]
        return T

    def collides(self, q: np.ndarray) -> str | None:
        """What collides at ``q`` (a message), or None: the arm's links against the
        furniture (``ArmIK.collides``), the plate against the furniture and the arm."""
        hit = self.ik.collides(q, clearance=self.clearance)
        if hit is not None:
            return hit
        m, d = self.model, self.data
        self._face_pose(q)  # kinematics of this model at q
        fromto = np.zeros(6)
        for a in self._plate:
            for b in self._furniture + self._upstream:
                if mujoco.mj_geomDistance(m, d, a, b, self.clearance + 0.05, fromto) < self.clearance:
                    return f"{m.geom(a).name} vs {m.geom(b).name}"
        return None

    def path_collides(self, qa: np.ndarray, qb: np.ndarray) -> str | None:
        """The first collision on the straight joint-space line from ``qa`` to ``qb``."""
        n = max(1, int(np.ceil(np.abs(np.asarray(qb) - qa).max() / self.path_step)))
        for k in range(1, n + 1):
            hit = self.collides(qa + (qb - qa) * (k / n))
            if hit is not None:
                return hit
        return None

    def shows_board(self, q: np.ndarray) -> str | None:
        """Why the nominal camera would not see the whole board at ``q``, or None."""
        T = self._face_pose(q)
        why = self._in_view(T)
        if why is not None:
            return why
        cam = self.T_world_camera[:3, 3]
        geomid = np.zeros(1, dtype=np.int32)
        for p in self._ray_points @ T[:3, :3].T + T[:3, 3]:
            v = p - cam
            dist = np.linalg.norm(v)
            got = mujoco.mj_ray(self.model, self.data, cam, v / dist, None, 1, -1, geomid)
            if got < 0 or self.model.geom_bodyid[geomid[0]] != self._board_body or \
                    got < dist - 0.002:
                return "occluded"
        return None

    def _in_view(self, T: np.ndarray) -> str | None:
        """Why the pattern (and its quiet zone) at face pose ``T`` would not be seen
        whole and frontally enough by the nominal camera, or None (occlusion aside)."""
        cam = self.T_world_camera[:3, 3]
        Tcw = np.linalg.inv(self.T_world_camera)
        pc = (self._outline @ T[:3, :3].T + T[:3, 3]) @ Tcw[:3, :3].T + Tcw[:3, 3]
        if np.any(pc[:, 2] < 0.05):
            return "behind or too near the camera"
        uv = pc[:, :2] / pc[:, 2:] @ np.diag([self.K[0, 0], self.K[1, 1]]) + self.K[:2, 2]
        m = self.margin
        if (uv.min(axis=0) < m).any() or uv[:, 0].max() > self.width - 1 - m or \
                uv[:, 1].max() > self.height - 1 - m:
            return "outside the image"
        to_cam = cam - T[:3, 3]
        cos = T[:3, 2] @ to_cam / np.linalg.norm(to_cam)  # the face's normal
        if cos < math.cos(math.radians(self.max_view_angle)):
            return "seen too obliquely"
        return None

    # --- sampling ---------------------------------------------------------------------
    def target(self, rng: np.random.Generator) -> np.ndarray:
        """A board pose ``T_world_board`` drawn as the class docstring says: the READY
        orientation (face up, the board's x along world -x) turned about world z, then
        tilted; its centre offset in the view within the room the pattern has."""
        depth = rng.uniform(*self.depth)
        turn = math.radians(rng.uniform(*self.turn))
        phi = rng.uniform(0, 2 * math.pi)
        tilt = math.radians(rng.uniform(*self.tilt))
        # the room the pattern's outline, turned, has to move in at this depth (flat)
        hx, hy = np.abs(self._outline[0, :2])
        c, s = abs(math.cos(turn)), abs(math.sin(turn))
        room_x = depth * (self.width / 2 - self.margin) / self.K[0, 0] - (c * hx + s * hy)
        room_y = depth * (self.height / 2 - self.margin) / self.K[1, 1] - (s * hx + c * hy)
        cam = self.T_world_camera[:3, 3]
        centre = cam + np.array([rng.uniform(-1, 1) * self.spread * max(room_x, 0.0),
                                 rng.uniform(-1, 1) * self.spread * max(room_y, 0.0), -depth])
        R = _rot([math.cos(phi), math.sin(phi), 0.0], tilt) @ _rot([0, 0, 1], turn) @ _FLAT
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, centre
        return T

    def solve(self, T_world_board: np.ndarray, seed: np.ndarray) -> np.ndarray:
        """Joint angles (6,) rad that put the board within ``target_tolerance`` of
        ``T_world_board``, from ``seed`` (mink, with ``ArmIK``'s tasks and its joint and
        speed limits: the posture task keeps the arm on the seed's branch). The poses are
        drawn at random and every check (collisions included: ``ArmIK``'s collision
        limit, which holds the wrist back over the belt, is left out) is made at the
        solution, so a close pose will do. Raises ``IKError`` when none is found in
        ``ik_iterations``."""
        return self.ik.solve_pose(T_world_board @ self._T_board_tcp, seed,
                                  tolerance=self.target_tolerance, iterations=self.ik_iterations,
                                  limits=self._limits, what="flange board pose")

    def propose(self, n: int, *, seed: int, start: np.ndarray | None = None,
                max_tries: int | None = None) -> np.ndarray:
        """``n`` joint configurations (n, 6) rad; see ``propose_flange_board_poses``."""
        if n < 1:
            raise SimError(f"flange board poses: n must be >= 1, got {n}")
        rng = np.random.default_rng(seed)
        q_start = np.array(HOME if start is None else start, dtype=np.float64)
        if q_start.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(q_start)):
            raise SimError(f"flange board poses: start must be 6 finite joint angles, got "
                          f"{q_start}")
        q_prev = q_start
        out: list[np.ndarray] = []
        tries = 0
        limit = max_tries if max_tries is not None else 200 * n
        self.rejected = {}
        while len(out) < n:
            if tries >= limit:
                raise IKError(f"flange board poses: only {len(out)} of {n} found in {tries} "
                              f"tries (rejected: {self.rejected})")
            tries += 1
            target = self.target(rng)
            why = self._in_view(target @ _FACE)  # the drawn pose itself: no IK for it
            if why is not None:
                self._reject(f"{why} (drawn)")
                continue
            try:
                q = self.solve(target, READY)
            except IKError:
                self._reject("ik")
                continue
            why = self.collides(q) and "collision"
            why = why or self.shows_board(q)
            if why is None and (self.path_collides(q_prev, q) is not None
                                or self.path_collides(q_start, q) is not None):
                why = "path collision"
            if why is not None:
                self._reject(why)
                continue
            out.append(q)
            q_prev = q
        return np.array(out)

    def _reject(self, why: str) -> None:
        self.rejected[why] = self.rejected.get(why, 0) + 1


def propose_flange_board_poses(
    n: int = 20, *, seed: int = 0, fovy: float = 40.0, width: int = 640, height: int = 480,
    start: np.ndarray | None = None, ik: ArmIK | None = None, **sampler,
) -> np.ndarray:
    """``n`` diverse joint configurations (n, 6) rad that show the flange board whole to
    the overhead camera, each collision-free and joined to the one before and to
    ``start`` (HOME by default) by collision-free straight joint-space lines: a capture
    may go start -> pose 1 -> ... -> pose n -> start, or home from any pose.

    ``seed`` seeds the ``np.random.Generator`` of the board poses (the same seed gives
    the same poses); ``fovy`` (deg), ``width`` and ``height`` (px) are the overhead
    camera's nominal lens and image (the scenario's ``camera`` section); ``sampler``
    passes ``BoardPoseSampler`` fields (``depth``, ``tilt``, ``turn``...). Raises
    ``IKError`` when ``n`` poses are not found in ``200 n`` draws (saying why they were
    rejected). Build the world with ``flange_board=True`` and put the arm at each with
    ``World.hold_arm`` (or move there with the arm's driver) to render the views.
    """
    return BoardPoseSampler(fovy=fovy, width=width, height=height, ik=ik, **sampler).propose(
        n, seed=seed, start=start)
