"""Lambertian shading with point lights (a ceiling light), shadows, and procedural textures.

Textures are evaluated in each mesh's local frame (``RenderMesh.world_from_local``), so all views of a
surface show the same pattern, and patterns differ between meshes through ``texture_seed``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.records import Camera
from rescene_core.render.raycast import RayCaster, RayHits, RenderMesh, Texture


@dataclass(frozen=True)
class Light:
    """A point light: world position (m), intensity (unitless) and distance falloff (1 / m^2)."""

    position: tuple[float, float, float]
    intensity: float = 1.0
    falloff: float = 0.04


@dataclass(frozen=True)
class Shading:
    """How surfaces are lit: ambient term, diffuse lights, cast shadows, display gamma."""

    lights: tuple[Light, ...] = ()
    ambient: float = 0.35
    shadows: bool = True
    shadow_strength: float = 0.6
    """Fraction of a light's diffuse term removed in its shadow (soft, since rooms bounce light)."""
    gamma: float = 1.0 / 1.6
    shadow_stride: int = 1
    """Cast shadow rays at every n-th pixel in x and y and repeat the result (speed against sharp shadows)."""


@dataclass(frozen=True)
class RenderedFrame:
    """One rendered view: rgb uint8 [H, W, 3]; depth float32 [H, W] metres along camera z (0 = miss);
    ids int32 [H, W] mesh id of the first hit (0 = miss)."""

    rgb: NDArray[np.uint8]
    depth: NDArray[np.float32]
    ids: NDArray[np.int32]
    hits: RayHits


def _hash(p: NDArray) -> NDArray[np.float64]:
    """A deterministic pseudo-random value in [0, 1) per row of integer-like coordinates [n, 3]."""
    s = np.sin(np.asarray(p, np.float64) @ np.array([12.9898, 78.233, 37.719])) * 43758.5453
    return s - np.floor(s)


def texture_factor(code: int, local: NDArray[np.float64], seed: NDArray[np.float64]) -> NDArray[np.float64]:
    """Multiplicative RGB factor [n, 3] (or [n, 1] for grey patterns) of one texture at local points [n, 3] (metres) with per-point seeds [n]."""
    local = local.astype(np.float32, copy=False)
    x, y, z = local[:, 0], local[:, 1], local[:, 2]
    ph = seed.astype(np.float32) * np.float32(37.0)
    if code == Texture.WOOD:
        g = 0.86 + 0.1 * np.sin(2 * np.pi * (x * 7.0 + 0.8 * np.sin(3.0 * (y + z) + ph) + ph))
        g += 0.04 * np.sin(x * 90.0 + ph)
        return g[:, None]
    if code == Texture.FABRIC:
        g = 0.93 + 0.04 * np.sin(x * 140.0 + ph) * np.sin((y + z) * 140.0) + 0.04 * np.sin(z * 11.0 + x * 5.0 + ph)
        return g[:, None]
    if code == Texture.PLANKS:
        width, length = 0.16, 1.3
        row = np.floor(y / width)
        col = np.floor((x + _hash(np.stack([row, row * 0 + 3.0, row * 0], 1)) * length) / length)
        plank = _hash(np.stack([row, col, row * 0 + 1.0], 1))
        g = 0.78 + 0.3 * plank + 0.06 * np.sin(x * 40.0 + 4.0 * np.sin(y * 20.0) + plank * 50)
        v = np.abs((y / width) - np.round(y / width)) < 0.04
        g = np.where(v, 0.55, g)
        return np.stack([g, g * 0.97, g * 0.92], 1)
    if code == Texture.PAINTING:
        k = 1.0 + 5.0 * seed[:, None]
        phases = np.stack([ph, ph * 1.7 + 1.0, ph * 2.3 + 2.0], 1)
        u = x[:, None] * np.array([9.0, 6.0, 11.0]) * k
        w = z[:, None] * np.array([7.0, 12.0, 5.0]) * k
        c = 0.55 + 0.45 * np.sin(u + np.sin(w + phases) * 2.0 + phases)
        return 0.35 + 1.4 * c
    if code == Texture.SCREEN:
        g = 0.5 + 0.5 * np.clip(z * 1.5, 0, 1)
        return np.stack([g * 0.8, g * 0.9, g * 1.2], 1)
    if code == Texture.FOLIAGE:
        cell = np.floor(local * 40.0)
        g = 0.6 + 0.6 * _hash(cell + ph[:, None])
        return np.stack([g * 0.9, g, g * 0.8], 1)
    if code == Texture.PAINT:
        g = 0.97 + 0.03 * np.sin(x * 3.0 + ph) * np.sin(y * 2.5 + z * 3.5)
        return g[:, None]
    g = 0.96 + 0.04 * np.sin(x * 13.0 + y * 7.0 + z * 11.0 + ph)
    return g[:, None]


class Renderer:
    """Renders RGB, depth and id buffers of a static scene of ``RenderMesh`` from any ``Camera``.

    One ray cast per frame gives depth, ids and the surface points; shading adds one shadow cast per
    light when ``shading.shadows`` is on (at every ``shading.shadow_stride``-th pixel).
    """

    def __init__(self, meshes: Sequence[RenderMesh], shading: Shading | None = None, threads: int = 0):
        self.caster = RayCaster(meshes, threads=threads)
        self.shading = shading or Shading()
        meshes = self.caster.meshes
        self.face_colors = np.concatenate([m.face_colors for m in meshes]).astype(np.float32)
        self.face_textures = np.concatenate([m.face_textures for m in meshes])
        rots, trans = [], []
        for m in meshes:
            rot, t = m.world_from_local[:3, :3], m.world_from_local[:3, 3]
            rots.append(rot.T)
            trans.append(-rot.T @ t)
        self.local_rot = np.stack(rots).astype(np.float32)  # [m, 3, 3] local_from_world rotation
        self.local_trans = np.stack(trans).astype(np.float32)  # [m, 3]
        self.seeds = np.array([m.texture_seed for m in meshes], np.float32)
        self.non_identity = np.array([not np.allclose(m.world_from_local, np.eye(4)) for m in meshes])

    def albedo(self, hits: RayHits) -> NDArray[np.float32]:
        """Textured albedo [H * W, 3] of every pixel (misses get the first mesh's; mask them with hits.hit)."""
        face = np.maximum(hits.face_index.ravel(), 0)
        mesh = np.maximum(hits.mesh_index.ravel(), 0)
        pts = hits.points.reshape(-1, 3)
        col = self.face_colors[face]
        codes = self.face_textures[face]
        # only meshes with a non-identity local frame pay for the per-pixel transform
        moving = self.non_identity[mesh]
        if moving.all():
            local = np.einsum("nij,nj->ni", self.local_rot[mesh], pts) + self.local_trans[mesh]
        else:
            local = pts.copy()
            idx = np.flatnonzero(moving)
            if len(idx):
                mi = mesh[idx]
                local[idx] = np.einsum("nij,nj->ni", self.local_rot[mi], pts[idx]) + self.local_trans[mi]
        seed = self.seeds[mesh]
        present = np.flatnonzero(np.bincount(codes, minlength=256))
        for code in present:
            if len(present) == 1:
                col *= texture_factor(int(code), local, seed)
            else:
                m = codes == code
                col[m] *= texture_factor(int(code), local[m], seed[m])
        return col

    def render(self, camera: Camera) -> RenderedFrame:
        """RGB, depth and ids of one camera (see ``RenderedFrame``)."""
        hits = self.caster.cast_camera(camera)
        h, w = hits.depth.shape
        col = self.albedo(hits)
        light = self.irradiance(hits)
        val = np.clip(col * light[:, None], 0.0, 1.0) ** np.float32(self.shading.gamma)
        rgb = (val * 255.0 + 0.5).astype(np.uint8).reshape(h, w, 3)
        rgb[~hits.hit] = 0
        return RenderedFrame(rgb=rgb, depth=hits.depth, ids=hits.ids, hits=hits)

    def irradiance(self, hits: RayHits) -> NDArray[np.float32]:
        """Ambient + diffuse light [H * W] at every pixel."""
        sh = self.shading
        h, w = hits.depth.shape
        pts = hits.points.reshape(-1, 3)
        nrm = hits.normals.reshape(-1, 3)
        total = np.full(len(pts), sh.ambient, np.float32)
        step = max(1, int(sh.shadow_stride))
        for light in sh.lights:
            lp = np.asarray(light.position, np.float32)
            d = lp - pts
            dist2 = np.einsum("ni,ni->n", d, d)
            cos = np.einsum("ni,ni->n", nrm, d) / np.sqrt(np.maximum(dist2, 1e-12))
            diffuse = light.intensity * np.clip(cos, 0.0, None) / (1.0 + light.falloff * dist2)
            if sh.shadows:
                grid = np.zeros((h, w), bool)
                grid[::step, ::step] = True
                sample = grid.ravel() & (cos > 0) & hits.hit.ravel()
                idx = np.flatnonzero(sample)
                occ = np.zeros(h * w, bool)
                occ[idx] = self.caster.occluded(pts[idx] + nrm[idx] * 2e-3, lp)
                if step > 1:
                    occ = occ.reshape(h, w)[::step, ::step]
                    occ = np.repeat(np.repeat(occ, step, 0), step, 1)[:h, :w].ravel()
                diffuse = np.where(occ, diffuse * (1.0 - sh.shadow_strength), diffuse)
            total += diffuse.astype(np.float32)
        return total


def render(meshes: Sequence[RenderMesh], camera: Camera, shading: Shading | None = None) -> RenderedFrame:
    """Render ``meshes`` from ``camera`` once (builds the ray-casting scene; use ``Renderer`` for many views)."""
    return Renderer(meshes, shading).render(camera)
