"""A realistic synthetic view of a box-shaped part, for the edge and corner tests.

A 40 x 30 x 20 mm box stands on a textured belt; a pinhole ``CameraModel`` looks at it
obliquely so the top and two side faces show. Faces are Lambert-shaded, drawn at 8x
resolution and area-averaged (anti-aliasing like a renderer's), then blurred by a
sigma-0.7 px lens and given sensor noise. The truth (visible vertices, silhouette)
comes from the same geometry.
"""

from __future__ import annotations

import cv2
import numpy as np

from cell.camera import CameraModel

SIZE = (0.040, 0.030, 0.020)  # metres
W, H = 320, 240
DEFAULT_YAW = float(np.radians(20))


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """T_world_camera with OpenCV axes (z forward, y down) at ``eye`` looking at ``target``."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, y, z], axis=1)
    T[:3, 3] = eye
    return T


def camera(eye=(-0.075, -0.10, 0.18)) -> CameraModel:
    f = 0.5 * H / np.tan(np.radians(40) / 2)
    K = np.array([[f, 0, (W - 1) / 2], [0, f, (H - 1) / 2], [0, 0, 1]])
    return CameraModel(W, H, K, np.zeros(5), look_at(eye, (0.0, 0.0, 0.01)))


def box_vertices(yaw=DEFAULT_YAW) -> np.ndarray:
    """The 8 corners (8, 3), index bits: x sign (1), y sign (2), top (4)."""
    lx, ly, lz = SIZE
    c, s = np.cos(yaw), np.sin(yaw)
    out = []
    for i in range(8):
        p = np.array([(i & 1) - 0.5, ((i >> 1) & 1) - 0.5, 0.0]) * [lx, ly, 0]
        out.append([c * p[0] - s * p[1], s * p[0] + c * p[1], lz if i & 4 else 0.0])
    return np.array(out)


FACES = {  # vertex indices (any order around the face), outward normal in box frame
    "top": ([4, 5, 7, 6], (0, 0, 1)),
    "-x": ([0, 2, 6, 4], (-1, 0, 0)),
    "+x": ([1, 3, 7, 5], (1, 0, 0)),
    "-y": ([0, 1, 5, 4], (0, -1, 0)),
    "+y": ([2, 3, 7, 6], (0, 1, 0)),
}


def render(
    cam: CameraModel,
    *,
    yaw=DEFAULT_YAW,
    shades=None,
    belt=70,
    texture=6.0,
    noise=2.5,
    seed=0,
    ss=8,
    light_ramp=0.0,
):
    """(image uint8 (H, W), visible vertex pixels (N, 2), silhouette bool (H, W),
    face-edge map bool (H, W): every visible box edge drawn 1 px wide).

    ``light_ramp``: illumination grows linearly left to right by this fraction of
    the mean, so every edge's contrast varies along its length."""
    rng = np.random.default_rng(seed)
    shades = shades or {"top": 210, "-x": 170, "+x": 170, "-y": 140, "+y": 140}
    V = box_vertices(yaw)
    c, s = np.cos(yaw), np.sin(yaw)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    eye = cam.T_world_camera[:3, 3]
    tex = rng.normal(0, texture, (H // 4 + 1, W // 4 + 1)).astype(np.float32)
    tex = cv2.resize(tex, (W * ss, H * ss), interpolation=cv2.INTER_CUBIC)
    big = np.full((H * ss, W * ss), float(belt), np.float32) + tex
    sil = np.zeros((H * ss, W * ss), np.uint8)
    edges = np.zeros((H, W), np.uint8)
    visible_vertices: set[int] = set()
    for name, (idx, normal) in FACES.items():
        n = Rz @ np.asarray(normal, float)
        centre = V[idx].mean(axis=0)
        if n @ (eye - centre) <= 0:
            continue
        visible_vertices.update(idx)
        px = cam.project(V[idx])
        poly = np.rint(px * ss + (ss - 1) / 2).astype(np.int32)
        cv2.fillConvexPoly(big, poly, float(shades[name]))
        cv2.fillConvexPoly(sil, poly, 1)
        cv2.polylines(edges, [np.rint(px).astype(np.int32)], True, 1)
    img = cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)
    if light_ramp:  # a light from the right: brightness grows left to right
        img *= (1.0 - light_ramp / 2 + light_ramp * np.arange(W) / (W - 1))[None, :]
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    img = img + rng.normal(0, noise, img.shape)
    silhouette = cv2.resize(sil.astype(np.float32), (W, H), interpolation=cv2.INTER_AREA) > 0.5
    verts = cam.project(V[sorted(visible_vertices)])
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), verts, silhouette, edges > 0


def corner_vertices(cam: CameraModel, *, yaw=DEFAULT_YAW, max_angle_deg=150.0) -> np.ndarray:
    """Pixels (N, 2) of the visible vertices that look like corners in the image: the
    sharpest angle between two visible box edges meeting there is below
    ``max_angle_deg`` (a vertex whose edges project almost onto one line is, to any
    detector, a point on a straight edge)."""
    V = box_vertices(yaw)
    c, s = np.cos(yaw), np.sin(yaw)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    eye = cam.T_world_camera[:3, 3]
    px = cam.project(V)
    edges: set[tuple[int, int]] = set()
    for idx, normal in FACES.values():
        if (Rz @ np.asarray(normal, float)) @ (eye - V[idx].mean(axis=0)) <= 0:
            continue
        for a, b in zip(idx, idx[1:] + idx[:1], strict=True):
            edges.add((min(a, b), max(a, b)))
    out = []
    for v in range(8):
        dirs = [px[b if a == v else a] - px[v] for a, b in edges if v in (a, b)]
        if len(dirs) < 2:
            continue
        best = 180.0
        for i in range(len(dirs)):
            for j in range(i + 1, len(dirs)):
                cosang = dirs[i] @ dirs[j] / np.linalg.norm(dirs[i]) / np.linalg.norm(dirs[j])
                best = min(best, float(np.degrees(np.arccos(np.clip(cosang, -1, 1)))))
        if best < max_angle_deg:
            out.append(px[v])
    return np.array(out)


def render_part(kind, finish, lighting, *, yaw, seed=2, x=0.0):
    """Render one part at rest under the overhead camera (cell.sim): returns the frame
    and the world (for ground truth used in scoring). Imports cell.sim lazily."""
    from cell.scenario import scenario_from_dict
    from cell.sim import World, layout

    scenario = scenario_from_dict(
        {"seed": seed, "lighting": lighting,
         "parts": {"count": 1, "kinds": [kind], "materials": [finish]}}
    )
    world = World.build(scenario, arm=False)
    part = world.place_next_part(x, layout.CONVEYOR_Y, yaw)
    world.step(150)
    frame = world.render("overhead", depth=False, seg=True)
    return frame, world, part


def bracket_outline_vertices(world, part) -> np.ndarray:
    """GROUND TRUTH for scoring: world points (N, 3) of the outline vertices of the top
    face of a part built from boxes (the L bracket), read from the simulator's geoms.

    In the part frame the boxes are axis-aligned; a candidate (any x edge, any y edge)
    is an outline vertex when 1 (convex) or 3 (concave) of the four points around it
    lie inside the union of the boxes."""
    import mujoco

    m, d = world.model, world.data
    body = part.body_id
    R, p = d.xmat[body].reshape(3, 3), d.xpos[body]
    rects = []
    for g in range(m.ngeom):
        if m.geom_bodyid[g] != body or m.geom_group[g] != 1:
            continue
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX:
            continue
        c, s = R.T @ (d.geom_xpos[g] - p), m.geom_size[g]
        rects.append((c[0] - s[0], c[0] + s[0], c[1] - s[1], c[1] + s[1], c[2] + s[2]))

    def inside(x, y):
        return any(a <= x <= b and lo <= y <= hi for a, b, lo, hi, _ in rects)

    xs = np.unique(np.round([v for r in rects for v in r[:2]], 7))
    ys = np.unique(np.round([v for r in rects for v in r[2:4]], 7))
    eps, out = 1e-5, []
    for x in xs:
        for y in ys:
            n = sum(inside(x + dx, y + dy) for dx in (-eps, eps) for dy in (-eps, eps))
            if n in (1, 3):
                out.append(p + R @ np.array([x, y, max(r[4] for r in rects)]))
    return np.array(out)
