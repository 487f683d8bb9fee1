"""Pure geometry for the rerun log: Gaussian ellipses/ellipsoids and MuJoCo geoms as rerun
archetypes."""

from __future__ import annotations

from collections import defaultdict

import mujoco
import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation

from humimic.sensors.camera_model import make_transform
from humimic.viz.entities import body_entity

_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)
_INFINITE_PLANE_HALF_M = 5.0
_WALL_HALF_SIZE_M = 2.0  # static boxes larger than this are drawn see-through


# ---- geometry helpers (pure) -------------------------------------------------------------------
def ellipse_points(centers: np.ndarray, covariances: np.ndarray, n_sigma: float,
                   n_points: int = 48) -> np.ndarray:
    """Closed outlines (N, n_points + 1, 2) of the ``n_sigma`` ellipses of 2-D Gaussians."""
    w, V = np.linalg.eigh(covariances)
    A = V * (n_sigma * np.sqrt(np.clip(w, 0.0, None)))[:, None, :]  # columns: scaled axes
    a = np.linspace(0.0, 2.0 * np.pi, n_points + 1)
    circle = np.stack([np.cos(a), np.sin(a)])  # (2, P)
    return centers[:, None, :] + np.einsum("nij,jp->npi", A, circle)


def label_anchors(centers: np.ndarray, covariances: np.ndarray, n_sigma: float,
                  labels: list[str], char_px: float = 7.0, line_px: float = 12.0,
                  gap_px: float = 3.0) -> np.ndarray:
    """Image positions (N, 2) for the labels of 2-D blobs: centred above each ``n_sigma``
    ellipse, each label a box ``char_px`` per character wide and ``line_px`` tall; a label whose
    box would overlap one already placed (left to right) moves up a line until it does not."""
    c = np.asarray(centers, float).reshape(-1, 2)
    top = c[:, 1] - n_sigma * np.sqrt(np.clip(np.asarray(covariances, float)[:, 1, 1], 0, None))
    out = np.stack([c[:, 0], top - gap_px - 0.5 * line_px], axis=1)
    half_w = 0.5 * char_px * np.array([len(s) for s in labels], float)
    placed: list[int] = []
    for i in np.argsort(c[:, 0], kind="stable").tolist():
        while any(abs(out[i, 0] - out[j, 0]) < half_w[i] + half_w[j]
                  and abs(out[i, 1] - out[j, 1]) < line_px for j in placed):
            out[i, 1] -= line_px
        placed.append(i)
    return out


def ellipsoid_axes(covariances: np.ndarray, n_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Half-sizes (N, 3) and rotations as xyzw quaternions (N, 4) of ``n_sigma`` ellipsoids."""
    w, V = np.linalg.eigh(covariances)
    V = V.copy()
    V[np.linalg.det(V) < 0, :, 2] *= -1.0  # a proper rotation
    return n_sigma * np.sqrt(np.clip(w, 0.0, None)), Rotation.from_matrix(V).as_quat()


def rigid_root(m: mujoco.MjModel, b: int) -> int:
    """The nearest ancestor-or-self with a joint or mocap (0: welded to the world)."""
    while b != 0 and m.body_jntnum[b] == 0 and m.body_mocapid[b] < 0:
        b = int(m.body_parentid[b])
    return b


def _geom_rgba(m: mujoco.MjModel, g: int) -> np.ndarray:
    """Display colour (uint8 RGBA): geom rgba if set, else material rgba x mean texture colour."""
    rgba = m.geom_rgba[g].astype(np.float32)
    mat = int(m.geom_matid[g])
    if mat >= 0 and np.allclose(rgba, _DEFAULT_RGBA):
        rgba = m.mat_rgba[mat].astype(np.float32).copy()
        tex = int(m.mat_texid[mat, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)])
        if tex >= 0:
            n, adr = int(m.tex_nchannel[tex]), int(m.tex_adr[tex])
            size = int(m.tex_width[tex] * m.tex_height[tex]) * n
            texels = m.tex_data[adr:adr + size].reshape(-1, n)[:, :3]
            rgba[:3] *= texels.mean(axis=0) / 255.0
    return np.round(np.clip(rgba, 0.0, 1.0) * 255).astype(np.uint8)


def geom_archetypes(m: mujoco.MjModel, geoms: list[tuple[int, np.ndarray]], static: bool):
    """(kind, archetype) batches for geoms given as (geom id, T_frame_geom)."""
    G = mujoco.mjtGeom
    out: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for g, T in geoms:
        typ, size, R, p = int(m.geom_type[g]), m.geom_size[g], T[:3, :3], T[:3, 3]
        q = Rotation.from_matrix(R).as_quat()
        rgba, name = _geom_rgba(m, g), m.geom(g).name or f"geom{g}"
        if typ == G.mjGEOM_MESH:
            mid = int(m.geom_dataid[g])
            v0, nv = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
            f0, nf = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
            verts = m.mesh_vert[v0:v0 + nv] @ R.T + p
            yield f"mesh_{name}", rr.Mesh3D(vertex_positions=verts,
                                            triangle_indices=m.mesh_face[f0:f0 + nf],
                                            albedo_factor=rgba)
            continue
        if typ == G.mjGEOM_PLANE:
            kind, half = "planes", np.array([size[0] or _INFINITE_PLANE_HALF_M,
                                             size[1] or _INFINITE_PLANE_HALF_M, 1e-3])
            p = p - R[:, 2] * 1e-3  # top face on the plane
        elif typ == G.mjGEOM_BOX:
            big = static and size[:3].max() > _WALL_HALF_SIZE_M
            kind, half = ("walls" if big else "boxes"), size[:3]
        elif typ in (G.mjGEOM_SPHERE, G.mjGEOM_ELLIPSOID):
            kind = "ellipsoids"
            half = np.full(3, size[0]) if typ == G.mjGEOM_SPHERE else size[:3]
        elif typ in (G.mjGEOM_CAPSULE, G.mjGEOM_CYLINDER):
            kind = "capsules" if typ == G.mjGEOM_CAPSULE else "cylinders"
            half = size[:2]
            if typ == G.mjGEOM_CAPSULE:  # rerun capsules start at their translation
                p = p - R[:, 2] * size[1]
        else:
            continue  # heightfields and SDFs are not drawn
        for key, value in (("p", p), ("q", q), ("half", half), ("rgba", rgba), ("name", name)):
            out[kind][key].append(value)
    for kind, b in out.items():
        common = dict(quaternions=b["q"], colors=b["rgba"], labels=b["name"], show_labels=False)
        half = np.array(b["half"])
        if kind in ("capsules", "cylinders"):
            pos = {"translations" if kind == "capsules" else "centers": b["p"]}
            cls = rr.Capsules3D if kind == "capsules" else rr.Cylinders3D
            yield kind, cls(lengths=2 * half[:, 1], radii=half[:, 0],
                            fill_mode=rr.components.FillMode.Solid, **pos, **common)
        else:
            fill = (rr.components.FillMode.TransparentFillMajorWireframe if kind == "walls"
                    else rr.components.FillMode.Solid)
            cls = rr.Ellipsoids3D if kind == "ellipsoids" else rr.Boxes3D
            yield kind, cls(centers=b["p"], half_sizes=half, fill_mode=fill, **common)


def scene_geoms(m: mujoco.MjModel, groups: tuple[int, ...]):
    """Every geom in MuJoCo ``groups``, per body entity, posed in its entity's frame.

    Returns ``(per_entity, static_bodies)``: ``per_entity[entity]`` lists ``(geom, T_frame_geom)``
    (the frame is the geom's moving ancestor, :func:`rigid_root`, or a static body's own frame);
    ``static_bodies[entity]`` is T_world_body of each body welded to the world. Relative geom
    poses do not depend on the configuration, so the model's default one is used.
    """
    d0 = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d0)
    per_entity: dict[str, list[tuple[int, np.ndarray]]] = defaultdict(list)
    static_bodies: dict[str, np.ndarray] = {}
    for g in range(m.ngeom):
        if int(m.geom_group[g]) not in groups:
            continue
        b = int(m.geom_bodyid[g])
        root = rigid_root(m, b)
        frame = b if root == 0 else root  # static bodies keep their own entity
        entity = body_entity(m, frame)
        T_world_frame = make_transform(d0.xmat[frame].reshape(3, 3), d0.xpos[frame])
        T_world_geom = make_transform(d0.geom_xmat[g].reshape(3, 3), d0.geom_xpos[g])
        per_entity[entity].append((g, np.linalg.inv(T_world_frame) @ T_world_geom))
        if root == 0 and frame != 0:
            static_bodies[entity] = T_world_frame
    return per_entity, static_bodies
