"""The parts: one free body per part, built from the catalogue's real sizes.

Each kind has a visual shape (meshes with their real through holes, so a washer looks
like a washer from above) and collision shapes (convex primitives: a mesh's convex hull
would fill the hole anyway). Collision geoms sit in geom group 3, which the cameras do
not render; visual geoms have no contacts. Masses come from the real material density.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from cell.catalogue import KINDS, MATERIALS, PartKind

__all__ = ["COLLISION_GROUP", "DENSITY", "add_part", "add_part_materials"]

COLLISION_GROUP = 3
DENSITY = {"steel": 7850.0, "aluminium": 2700.0, "brass": 8500.0, "plastic": 1200.0}
_MESH_KINDS = ("washer", "hex_nut", "square_nut", "bolt")
# Offsets (m) that put the body origin at the centroid of the part's silhouette from above,
# so "position" means the same thing to the simulator and to the detector.
_BOLT_DX = 0.0015  # shaft 40x6 mm at x=+2 mm, head 4x11.5 mm at x=-20 mm
_BRACKET_D = 0.004345  # centroid of the L (legs 40x12 and 30x12 mm) from its bbox centre
_SEGMENTS = 48  # samples around a ring; a multiple of 6 and 4 keeps hex/square corners exact


def _density(finish: str) -> float:
    m = MATERIALS[finish]
    return DENSITY[m.colour] if m.material == "metal" else DENSITY["plastic"]


def _ring_radius(shape: str, apothem: float, theta: np.ndarray) -> np.ndarray:
    """Distance from the centre to a regular polygon's edge in direction ``theta``.

    ``shape`` is ``circle``, ``hex`` (corners at 0, 60, ... deg) or ``square`` (corners at
    45, 135, ... deg); ``apothem`` is the inscribed radius (metres).
    """
    if shape == "circle":
        return np.full_like(theta, apothem)
    sides = 6 if shape == "hex" else 4
    offset = math.pi / sides if shape == "hex" else 0.0
    sector = 2 * math.pi / sides
    rel = np.mod(theta - offset + sector / 2, sector) - sector / 2
    return apothem / np.cos(rel)


def _prism_mesh(
    shape: str, apothem: float, hole: float, height: float
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) of a prism with an optional round hole.

    The prism is centred at the origin, its axis along z. Each face group (top, bottom,
    outer wall, inner wall) has its own vertices so edges render sharp.
    """
    n = _SEGMENTS
    theta = np.arange(n) * 2 * math.pi / n
    r_out = _ring_radius(shape, apothem, theta)
    outer = np.stack([r_out * np.cos(theta), r_out * np.sin(theta)], axis=1)
    h = height / 2
    verts: list[np.ndarray] = []
    faces: list[list[int]] = []

    def ring(xy: np.ndarray, z: float) -> int:
        start = sum(len(v) for v in verts)
        verts.append(np.column_stack([xy, np.full(len(xy), z)]))
        return start

    def band(a: int, b: int, flip: bool) -> None:
        for i in range(n):
            j = (i + 1) % n
            tri1, tri2 = [a + i, a + j, b + j], [a + i, b + j, b + i]
            if flip:
                tri1, tri2 = tri1[::-1], tri2[::-1]
            faces.extend([tri1, tri2])

    if hole > 0:
        inner = np.stack([np.cos(theta), np.sin(theta)], axis=1) * (hole / 2)
        # top (z up): outer -> inner counter-clockwise seen from above
        band(ring(inner, h), ring(outer, h), flip=True)
        band(ring(inner, -h), ring(outer, -h), flip=False)
        band(ring(outer, -h), ring(outer, h), flip=False)  # outer wall
        band(ring(inner, -h), ring(inner, h), flip=True)  # inner wall
    else:
        top_c, bot_c = ring(np.zeros((1, 2)), h), ring(np.zeros((1, 2)), -h)
        top, bot = ring(outer, h), ring(outer, -h)
        for i in range(n):
            j = (i + 1) % n
            faces.append([top_c, top + i, top + j])
            faces.append([bot_c, bot + j, bot + i])
        band(ring(outer, -h), ring(outer, h), flip=False)
    return np.concatenate(verts), np.array(faces, dtype=np.int64)


def _add_mesh(spec: mujoco.MjSpec, name: str, verts: np.ndarray, faces: np.ndarray) -> None:
    mesh = spec.add_mesh()
    mesh.name = name
    mesh.uservert = verts.astype(np.float64).ravel().tolist()
    mesh.userface = faces.astype(np.int32).ravel().tolist()


def _ensure_meshes(spec: mujoco.MjSpec, kind: PartKind) -> None:
    """Add the kind's meshes to the spec once (shared by every part of that kind)."""
    if kind.name not in _MESH_KINDS or spec.mesh(f"{kind.name}_visual") is not None:
        return
    if kind.name == "washer":
        _add_mesh(spec, "washer_visual", *_prism_mesh("circle", 0.010, kind.hole, kind.height))
    elif kind.name == "hex_nut":
        _add_mesh(spec, "hex_nut_visual", *_prism_mesh("hex", 0.0085, kind.hole, kind.height))
        _add_mesh(spec, "hex_nut_hull", *_prism_mesh("hex", 0.0085, 0.0, kind.height))
    elif kind.name == "square_nut":
        _add_mesh(spec, "square_nut_visual", *_prism_mesh("square", 0.0065, kind.hole, kind.height))
    elif kind.name == "bolt":
        _add_mesh(spec, "bolt_visual", *_prism_mesh("hex", 0.005, 0.0, 0.004))


def add_part_materials(spec: mujoco.MjSpec) -> None:
    """One MuJoCo material per finish in the catalogue, named ``part_<finish>``.

    Metals get a fine random grain (a builtin texture: a machined surface's speckle) on
    top of their specular finish; plastics are smooth and matte.
    """
    grain = spec.add_texture()
    grain.name = "metal_grain"
    grain.type = mujoco.mjtTexture.mjTEXTURE_2D
    grain.builtin = mujoco.mjtBuiltin.mjBUILTIN_FLAT
    grain.mark = mujoco.mjtMark.mjMARK_RANDOM
    grain.random = 0.35
    grain.rgb1 = [1.0, 1.0, 1.0]
    grain.markrgb = [0.72, 0.72, 0.72]
    grain.width = grain.height = 128
    for finish in MATERIALS.values():
        mat = spec.add_material()
        mat.name = f"part_{finish.name}"
        mat.rgba = list(finish.rgba)
        mat.specular = finish.specular
        mat.shininess = finish.shininess
        mat.reflectance = 0.0
        if finish.material == "metal":
            mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "metal_grain"
            mat.texuniform = True
            mat.texrepeat = [40.0, 40.0]


def add_part(
    spec: mujoco.MjSpec, name: str, kind_name: str, finish: str, pos: np.ndarray
) -> mujoco.MjsBody:
    """Add one part as a free body named ``name`` at ``pos`` (metres, world frame).

    The body frame's origin is the centre of the part's footprint, at half its height,
    its x axis along the part's length. Returns the body.
    """
    kind = KINDS[kind_name]
    _ensure_meshes(spec, kind)
    body = spec.worldbody.add_body(name=name, pos=list(pos))
    body.add_freejoint(name=f"{name}_free")
    density = _density(finish)
    mat = f"part_{finish}"

    def visual(**kw) -> None:
        body.add_geom(contype=0, conaffinity=0, density=0.0, material=mat, group=1, **kw)

    def collision(**kw) -> None:
        body.add_geom(density=density, group=COLLISION_GROUP, rgba=[1, 0, 0, 0],
                      friction=[0.8, 0.01, 0.001], condim=4, **kw)

    mesh_t, cyl, box = mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_BOX
    h = kind.height / 2
    if kind.name == "washer":
        visual(type=mesh_t, meshname="washer_visual")
        collision(type=cyl, size=[0.010, h, 0])
    elif kind.name == "hex_nut":
        visual(type=mesh_t, meshname="hex_nut_visual")
        collision(type=mesh_t, meshname="hex_nut_hull")
    elif kind.name == "square_nut":
        visual(type=mesh_t, meshname="square_nut_visual")
        collision(type=box, size=[0.0065, 0.0065, h])
    elif kind.name == "bolt":
        # M6x40 lying along x: shaft radius 3 mm, hex head 10 mm across flats, 4 mm thick,
        # resting on one of the head's flats (so it cannot roll) and the shaft's tip.
        shaft_quat = [math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0]  # z -> x
        head_quat = np.zeros(4)  # then 30 deg about the axis: a flat faces down
        mujoco.mju_mulQuat(head_quat, np.array(shaft_quat),
                           np.array([math.cos(math.pi / 12), 0, 0, math.sin(math.pi / 12)]))
        head_quat = head_quat.tolist()
        for fn in (visual, collision):
            fn(type=cyl, size=[0.003, 0.020, 0], pos=[0.002 + _BOLT_DX, 0, 0], quat=shaft_quat)
            fn(type=mesh_t, meshname="bolt_visual", pos=[-0.020 + _BOLT_DX, 0, 0], quat=head_quat)
    elif kind.name == "l_bracket":
        # Two 12 mm wide legs of 40 and 30 mm, the footprint centred on the body origin.
        w, d = 0.012, _BRACKET_D
        legs = ([kind.length / 2, w / 2, h], [d, -kind.width / 2 + w / 2 + d, 0.0]), (
            [w / 2, kind.width / 2, h], [-kind.length / 2 + w / 2 + d, d, 0.0])
        for size, pos in legs:
            for fn in (visual, collision):
                fn(type=box, size=size, pos=pos)
    elif kind.name == "disc":
        for fn in (visual, collision):
            fn(type=cyl, size=[kind.length / 2, h, 0])
    return body
