"""USD export (``scene/scene.usda``, or ``scene.usdc`` with ``ExportConfig.usd_binary``) with usd-core (pxr).

Stage: upAxis Z, metersPerUnit 1, kilogramsPerUnit 1, default prim ``/World``, a ``PhysicsScene``
(gravity -Z, 9.81 m/s^2). ``/World/Shell``: the floor slab and wall boxes as static colliders (meshes
with CollisionAPI, no rigid body). ``/World/Objects/<node>``: one Xform per object carrying its pose
(translate, orient, uniform scale of world_from_asset), a ``visual`` mesh (asset frame) and the convex
collision pieces ``collision_<k>`` (the same pieces as the MJCF, purpose ``guide``, CollisionAPI +
MeshCollisionAPI convexHull). Free objects get RigidBodyAPI and MassAPI (the MJCF's mass); mounted
objects stay static colliders. Each object has a physics material with the category's friction and the
scene-graph relation as custom attributes ``rescene:instance``, ``rescene:label``, ``rescene:relation``,
``rescene:parent``, ``rescene:confidence``, ``rescene:bodyKind``. ``<node>`` is the object's name
(rescene_core/names.py: an identifier, so every prim is a direct child of ``/World/Objects``); the
label verbatim is also the prim's ``customData`` ``rescene:label`` and its ``displayName``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from rescene_core.colliders.decompose import Decomposition
from rescene_core.config import ExportConfig
from rescene_core.export.mjcf import BodyRecord
from rescene_core.export.objects import ExportObject
from rescene_core.export.physics_tables import SHELL_FRICTION
from rescene_core.export.shell import shell_meshes
from rescene_core.records import InstanceId, RoomShell, SceneGraph, parent_to_json

LABEL_KEY = "rescene:label"
"""Key path of an object prim's ``customData`` entry holding its label verbatim (``Usd.Prim.GetCustomDataByKey``)."""
GRAVITY = 9.81
"""Magnitude of the PhysicsScene's gravity (m/s^2)."""


def _mesh(stage, path: str, vertices: np.ndarray, faces: np.ndarray):
    from pxr import UsdGeom, Vt

    mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.asarray(vertices, np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(faces, np.int32).reshape(-1)))
    mesh.CreateSubdivisionSchemeAttr("none")
    if len(points):
        mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([points.min(axis=0), points.max(axis=0)])))
    return mesh


def _material(stage, path: str, friction: float):
    from pxr import UsdPhysics, UsdShade

    material = UsdShade.Material.Define(stage, path)
    api = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
    api.CreateStaticFrictionAttr(float(friction))
    api.CreateDynamicFrictionAttr(float(friction))
    api.CreateRestitutionAttr(0.0)
    return material


def _bind(prim, material) -> None:
    from pxr import UsdShade

    UsdShade.MaterialBindingAPI.Apply(prim).Bind(
        material, UsdShade.Tokens.weakerThanDescendants, materialPurpose="physics"
    )


def _collider(prim, approximation: str) -> None:
    from pxr import UsdPhysics

    UsdPhysics.CollisionAPI.Apply(prim)
    UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(approximation)


def load_usd() -> None:
    """Load OpenUSD's libraries (``pxr``) in the calling thread, once per process.

    Call it before another thread of the process may be running numpy. Loading ``pxr`` runs the libraries'
    static initialisers inside ``dlopen``, and they take the GIL (``TfPyLock``) while the loader's lock is
    held; numpy, holding the GIL, takes the loader's lock to inspect its callers before it reuses a
    temporary array (``check_callers``). The two threads then wait on each other for ever: a run's export,
    writing the USD while the evaluation's metrics ran beside it (``rescene_core/stages/hooks.py``), hung
    in ``write_usd``'s first import."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics  # noqa: F401


def write_usd(
    path: Path,
    objects: list[ExportObject],
    shell: RoomShell | None,
    graph: SceneGraph | None,
    decompositions: dict[str, Decomposition],
    bodies: list[BodyRecord],
    config: ExportConfig,
) -> Path:
    """Write the stage (see the module doc) atomically; returns ``path``."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

    tmp = path.with_name(path.stem + ".tmp" + path.suffix)
    stage = Usd.Stage.CreateNew(str(tmp))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    scene = UsdPhysics.Scene.Define(stage, "/World/PhysicsScene")
    scene.CreateGravityDirectionAttr(Gf.Vec3f(0, 0, -1))
    scene.CreateGravityMagnitudeAttr(GRAVITY)
    UsdGeom.Scope.Define(stage, "/World/Materials")

    if shell is not None:
        UsdGeom.Xform.Define(stage, "/World/Shell")
        shell_material = _material(stage, "/World/Materials/shell", SHELL_FRICTION)
        for name, mesh in shell_meshes(shell, config).items():
            prim = _mesh(stage, f"/World/Shell/{name}", mesh.vertices, mesh.faces).GetPrim()
            _collider(prim, "none")
            _bind(prim, shell_material)

    UsdGeom.Xform.Define(stage, "/World/Objects")
    parents = graph.parent_of() if graph is not None else {}
    by_node = {b.node: b for b in bodies}
    for obj in sorted(objects, key=lambda o: o.instance):
        body = by_node[obj.node_name]
        root = f"/World/Objects/{obj.node_name}"
        xform = UsdGeom.Xform.Define(stage, root)
        pose = np.asarray(obj.world_from_asset, np.float64)
        scale = body.scale
        u, _, vt = np.linalg.svd(pose[:3, :3] / scale)
        x, y, z, w = Rotation.from_matrix(u @ vt).as_quat()
        xform.AddTranslateOp().Set(Gf.Vec3d(*pose[:3, 3]))
        xform.AddOrientOp().Set(Gf.Quatf(float(w), float(x), float(y), float(z)))
        xform.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
        prim = xform.GetPrim()
        if len(obj.faces):
            _mesh(stage, f"{root}/visual", obj.vertices, obj.faces)
        material = _material(stage, f"/World/Materials/{obj.node_name}", body.friction)
        for k, (pv, pf) in enumerate(decompositions[obj.node_name].pieces):
            piece = _mesh(stage, f"{root}/collision_{k}", np.asarray(pv) / scale, pf)
            piece.CreatePurposeAttr(UsdGeom.Tokens.guide)
            _collider(piece.GetPrim(), "convexHull")
            # bound on every collider too, not only inherited from the body: Newton's importer reads a
            # collider's own binding and falls back to friction 1.0 (USD apps that resolve inheritance
            # find the same material either way)
            _bind(piece.GetPrim(), material)
        if body.kind == "free":
            UsdPhysics.RigidBodyAPI.Apply(prim)
            UsdPhysics.MassAPI.Apply(prim).CreateMassAttr(float(body.mass))
        _bind(prim, material)
        edge = parents.get(InstanceId(obj.instance))
        attrs = {
            "rescene:instance": (Sdf.ValueTypeNames.Int, int(obj.instance)),
            "rescene:label": (Sdf.ValueTypeNames.String, obj.label),
            "rescene:bodyKind": (Sdf.ValueTypeNames.String, body.kind),
            "rescene:relation": (Sdf.ValueTypeNames.String, "" if edge is None else edge.relation.value),
            "rescene:parent": (Sdf.ValueTypeNames.String, "" if edge is None else str(parent_to_json(edge.parent))),
            "rescene:confidence": (Sdf.ValueTypeNames.Float, 0.0 if edge is None else float(edge.confidence)),
        }
        for name, (kind, value) in attrs.items():
            prim.CreateAttribute(name, kind, custom=True).Set(value)
        # the prim name is the label made an identifier (rescene_core/names.py); the label verbatim:
        prim.SetCustomDataByKey(LABEL_KEY, obj.label)
        if obj.label:
            prim.SetDisplayName(obj.label)
    stage.GetRootLayer().Save()
    del stage
    tmp.replace(path)
    return path


def validate_usd(path: str | Path) -> list[str]:
    """Errors the USD validators (``pxr.UsdValidation``, physics rules included) report on the stage."""
    from pxr import Usd, UsdValidation

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        return [f"{path}: Usd.Stage.Open failed"]
    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    errors = context.Validate(stage)
    return [
        f"{e.GetName()}: {e.GetMessage()}" for e in errors if e.GetType() == UsdValidation.ValidationErrorType.Error
    ]
