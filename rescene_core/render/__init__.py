"""CPU ray-cast rendering: RGB (Lambertian, ceiling light, procedural textures), depth and id buffers.

    renderer = Renderer([RenderMesh.uniform(1, vertices, faces, (0.8, 0.6, 0.4))],
                        Shading(lights=(Light((2.0, 2.0, 2.5)),)))
    frame = renderer.render(camera)   # frame.rgb uint8 [H,W,3], frame.depth float32 [H,W], frame.ids int32 [H,W]

Built on ``open3d.t.geometry.RaycastingScene``; depth is metres along the camera z axis, 0 = miss.
"""

from rescene_core.render.raycast import RayCaster, RayHits, RenderMesh, Texture, camera_rays
from rescene_core.render.shading import Light, RenderedFrame, Renderer, Shading, render, texture_factor

__all__ = [
    "Light",
    "RayCaster",
    "RayHits",
    "RenderMesh",
    "RenderedFrame",
    "Renderer",
    "Shading",
    "Texture",
    "camera_rays",
    "render",
    "texture_factor",
]
