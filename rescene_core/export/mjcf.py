"""MJCF export (``scene/mjcf/scene.xml`` + ``scene/mjcf/meshes/``), built with MuJoCo's ``mujoco.MjSpec``.

Bodies: the floor slab and one box per wall are static geoms of the world body. An object mounted on a
wall (``mounts-on``) and built-in structure (a fitted counter backed onto a wall,
rescene_core/export/structure.py) are bodies fixed to the world (no joint); every other object (on the floor, on
another object, or with no relation) is a free body. Each body has its visual mesh (group 1,
``contype = conaffinity = 0``, no mass) and its convex collision pieces (group 3) from
rescene_core/colliders/decompose.py. Mass = bulk density of the category x the closed mesh's volume
(rescene_core/export/physics_tables.py); MuJoCo computes the inertia from the collision pieces, whose
density is set so they carry exactly that mass. Friction per category.

Names: a body, its geoms ``<node>/visual`` and ``<node>/col<k>``, its meshes and their files
``meshes/<node>.stl``, ``meshes/<node>_col<k>.stl`` are named by the object's name (rescene_core/names.py,
the glTF node's); the label verbatim is a ``<custom><text name="rescene:label:<node>">`` element
(``mjcf_labels`` reads them back) and in scene.json.

Frames: world z up, metres, as the run. A body's frame is the object's pose with the scale taken out
(position t and rotation R of world_from_asset = [s R | t]); its meshes are the asset meshes scaled by s.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from rescene_core.colliders.decompose import Decomposition
from rescene_core.export.objects import ExportObject
from rescene_core.export.physics_tables import SHELL_FRICTION, PhysicsTable
from rescene_core.geometry.room import floor_height, wall_boxes
from rescene_core.geometry.sim3 import scale_of
from rescene_core.io import write_bytes_atomic
from rescene_core.names import MJCF_LABEL_TEXT
from rescene_core.records import InstanceId, Relation, RoomShell, SceneGraph

MESH_DIR = "meshes"
"""Mesh files of the MJCF, relative to scene.xml."""
VISUAL_GROUP = 1
"""MuJoCo geom group of the visual meshes."""
COLLISION_GROUP = 3
"""MuJoCo geom group of the collision pieces (and the shell slabs)."""
TIMESTEP = 0.002
"""Simulation time step written into the model (s)."""
FLOOR_MARGIN = 1.0
"""How far the floor slab reaches past the floor polygon's bounding box (m)."""
MIN_MASS = 0.05
"""Smallest mass of a free body (kg): a near-zero mass makes the simulation explode."""


@dataclass(frozen=True)
class BodyRecord:
    """What the exporter made of one object (the export report and the physics check read it)."""

    node: str
    instance: int
    label: str
    kind: str  # "free" or "fixed"
    mass: float
    volume: float
    density: float
    friction: float
    pieces: int
    method: str
    scale: float
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_json(self) -> dict[str, Any]:
        return {
            "node": self.node,
            "instance": self.instance,
            "label": self.label,
            "kind": self.kind,
            "mass_kg": round(self.mass, 6),
            "volume_m3": round(self.volume, 9),
            "density_kg_m3": self.density,
            "friction": self.friction,
            "collision_pieces": self.pieces,
            "collision_method": self.method,
            "scale": self.scale,
            "notes": list(self.notes),
        }


def body_kind(
    instance: int, graph: SceneGraph | None, built_in: Mapping[int, str] | None = None
) -> tuple[str, list[str]]:
    """'fixed' for an object mounted on something (a wall, or an object that is itself mounted) and for
    built-in structure (``built_in``: instance -> why, rescene_core/export/structure.py), else 'free'; and
    the notes for the export report."""
    edge = (graph.parent_of() if graph is not None else {}).get(InstanceId(int(instance)))
    if edge is None:
        return "free", ["no scene-graph relation: exported as a free body"]
    if edge.relation == Relation.MOUNTS_ON:
        return "fixed", []
    reason = (built_in or {}).get(int(instance))
    return ("fixed", [reason]) if reason else ("free", [])


def _stl(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    data = trimesh.Trimesh(vertices, faces, process=False).export(file_type="stl")
    assert isinstance(data, bytes)  # trimesh exports a binary format as bytes
    tmp = path.with_suffix(".tmp")
    tmp.write_bytes(data)
    tmp.replace(path)


def solid_points(vertices: np.ndarray) -> bool:
    """Whether MuJoCo can build a mesh from these points: finite, at least 4, not all on one plane."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    if len(v) < 4 or not np.isfinite(v).all():
        return False
    singular = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
    return bool(singular[-1] > 1e-6 * max(singular[0], 1e-12))


def closed_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, list[str]]:
    """Volume of a mesh (m^3) and notes: the mesh's own when it is closed, else its convex hull's."""
    mesh = trimesh.Trimesh(vertices, faces, process=True)
    if mesh.is_watertight and mesh.volume > 1e-9:
        return float(mesh.volume), []
    try:
        return float(mesh.convex_hull.volume), ["volume of the convex hull: the mesh is not closed"]
    except Exception:  # flat or degenerate mesh: the caller falls back to the collider's volume
        return 0.0, ["mesh has no volume"]


def build_spec(
    objects: list[ExportObject],
    shell: RoomShell | None,
    graph: SceneGraph | None,
    decompositions: dict[str, Decomposition],
    table: PhysicsTable,
    out_dir: Path,
    wall_height: float,
    wall_thickness: float,
    floor_thickness: float,
    built_in: Mapping[int, str] | None = None,
) -> tuple[Any, list[BodyRecord]]:
    """The ``mujoco.MjSpec`` of the scene (mesh files written under ``out_dir/meshes``) and a record per body.

    decompositions: node name -> convex pieces of the object's mesh scaled by its pose's scale.
    built_in: instance -> why it is built-in structure, fixed to the world (``body_kind``); None: only
    mounted objects are fixed.
    """
    import mujoco

    spec = mujoco.MjSpec()
    spec.modelname = "rescene"
    spec.meshdir = MESH_DIR
    spec.modelfiledir = str(out_dir)
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.compiler.inertiagrouprange = [COLLISION_GROUP, COLLISION_GROUP]
    world = spec.worldbody
    z0 = floor_height(shell) if shell is not None else 0.0
    if shell is not None:
        poly = np.asarray(shell.floor_polygon, np.float64)
        lo, hi = poly.min(axis=0) - FLOOR_MARGIN, poly.max(axis=0) + FLOOR_MARGIN
        world.add_geom(
            name="shell_floor",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, floor_thickness / 2],
            pos=[(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, z0 - floor_thickness / 2],
            friction=[SHELL_FRICTION, 0.005, 0.0001],
            group=COLLISION_GROUP,
            rgba=[0.8, 0.8, 0.78, 1],
        )
        height = shell.ceiling_height if shell.ceiling_height else wall_height
        for wall_id, centre, yaw, length in wall_boxes(shell, wall_thickness, height):
            world.add_geom(
                name=f"shell_wall_{wall_id}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[length / 2, wall_thickness / 2, height / 2],
                pos=centre.tolist(),
                quat=[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)],
                friction=[SHELL_FRICTION, 0.005, 0.0001],
                group=COLLISION_GROUP,
                rgba=[0.9, 0.9, 0.88, 0.3],
            )
    records: list[BodyRecord] = []
    for obj in sorted(objects, key=lambda o: o.instance):
        name = obj.node_name
        pose = np.asarray(obj.world_from_asset, np.float64)
        scale = scale_of(pose) or 1.0
        u, _, vt = np.linalg.svd(pose[:3, :3] / scale)
        rot = u @ vt
        quat_xyzw = Rotation.from_matrix(rot).as_quat()
        kind, notes = body_kind(obj.instance, graph, built_in)
        density, friction, guesses = table.lookup(obj.label)
        notes += guesses
        vertices = np.asarray(obj.vertices, np.float64) * scale
        dec = decompositions[name]
        notes += list(dec.notes)
        volume, vnotes = closed_volume(vertices, np.asarray(obj.faces))
        notes += vnotes
        if volume <= 0:
            volume = dec.volume
            notes.append(f"volume of the collision pieces ({volume:.3g} m^3)")
        mass = density * volume
        if kind == "free" and mass < MIN_MASS:
            notes.append(f"mass {mass:.3g} kg raised to the floor of {MIN_MASS} kg")
            mass = MIN_MASS
        body = world.add_body(name=name, pos=pose[:3, 3].tolist(), quat=[quat_xyzw[3], *quat_xyzw[:3]])
        if obj.label and "]]>" not in obj.label:  # MuJoCo refuses an empty text; its writer cuts at "]]>"
            spec.add_text(name=f"{MJCF_LABEL_TEXT}{name}", data=obj.label)
        if kind == "free":
            body.add_freejoint(name=f"{name}/free")
        if not solid_points(vertices):
            notes.append("visual mesh left out of the MJCF: MuJoCo needs at least 4 points spanning a volume")
        else:
            _stl(out_dir / MESH_DIR / f"{name}.stl", vertices, np.asarray(obj.faces))
            vis = spec.add_mesh(name=f"{name}/visual", file=f"{name}.stl")
            vis.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            body.add_geom(
                name=f"{name}/visual",
                type=mujoco.mjtGeom.mjGEOM_MESH,
                meshname=f"{name}/visual",
                contype=0,
                conaffinity=0,
                group=VISUAL_GROUP,
                density=0,
                rgba=[0.7, 0.6, 0.5, 1],
            )
        piece_volume = dec.volume
        for k, (pv, pf) in enumerate(dec.pieces):
            _stl(out_dir / MESH_DIR / f"{name}_col{k}.stl", pv, pf)
            spec.add_mesh(name=f"{name}/col{k}", file=f"{name}_col{k}.stl")
            body.add_geom(
                name=f"{name}/col{k}",
                type=mujoco.mjtGeom.mjGEOM_MESH,
                meshname=f"{name}/col{k}",
                group=COLLISION_GROUP,
                density=mass / piece_volume if piece_volume > 0 else 1000.0,
                friction=[friction, 0.005, 0.0001],
                rgba=[0.3, 0.5, 0.8, 0.4],
            )
        records.append(
            BodyRecord(
                name,
                int(obj.instance),
                obj.label,
                kind,
                float(mass),
                float(volume),
                density,
                friction,
                len(dec.pieces),
                dec.method,
                scale,
                tuple(notes),
            )
        )
    return spec, records


def mjcf_labels(model: Any) -> dict[str, str]:
    """{body name: label} of a compiled ``mujoco.MjModel`` exported here, from its ``rescene:label:<name>``
    text elements (an object whose label is empty has none)."""
    import mujoco

    out = {}
    for i in range(model.ntext):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
        if name.startswith(MJCF_LABEL_TEXT):
            start, size = int(model.text_adr[i]), int(model.text_size[i])
            out[name[len(MJCF_LABEL_TEXT) :]] = bytes(model.text_data[start : start + size - 1]).decode()
    return out


def write_mjcf(spec: Any, out_dir: Path) -> Path:
    """Compile ``spec``, write ``out_dir/scene.xml`` and check it loads back with ``MjModel.from_xml_path``."""
    import mujoco

    spec.compile()
    path = out_dir / "scene.xml"
    write_bytes_atomic(path, spec.to_xml().encode())
    mujoco.MjModel.from_xml_path(str(path))
    return path
