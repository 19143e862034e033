"""Renderer: depth along camera z, id buffer, shading and textures, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.records import Camera
from rescene_core.render import Light, Renderer, RenderMesh, Shading, Texture, camera_rays, render


def _camera(width=64, height=48, f=50.0, eye=(0.0, 0.0, 0.0)):
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])
    pose = np.eye(4)
    pose[:3, 3] = eye
    return Camera(K, pose, width, height)


def _wall(z: float, mesh_id: int, color=(0.8, 0.8, 0.8), texture=Texture.PLAIN) -> RenderMesh:
    v = np.array([[-10, -10, z], [10, -10, z], [10, 10, z], [-10, 10, z]], float)
    return RenderMesh.uniform(mesh_id, v, [[0, 1, 2], [0, 2, 3]], color, texture)


def test_depth_is_distance_along_camera_z():
    frame = render([_wall(3.0, 7)], _camera())
    assert frame.rgb.shape == (48, 64, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.dtype == np.float32 and frame.ids.dtype == np.int32
    # every pixel sees the plane z = 3 at depth 3, even at the image corners (oblique rays)
    np.testing.assert_allclose(frame.depth, 3.0, atol=1e-5)
    assert (frame.ids == 7).all()


def test_nearest_mesh_wins_and_misses_are_zero():
    box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    box.apply_translation([0, 0, 2.0])
    meshes = [RenderMesh.uniform(3, box.vertices, box.faces, (0.2, 0.6, 0.2)), _wall(5.0, 9)]
    frame = Renderer(meshes).render(_camera())
    assert frame.ids[24, 32] == 3
    np.testing.assert_allclose(frame.depth[24, 32], 1.75, atol=1e-5)
    assert frame.ids[0, 0] == 9
    empty = render([box and RenderMesh.uniform(3, box.vertices, box.faces, (1, 1, 1))], _camera())
    assert empty.ids[0, 0] == 0 and empty.depth[0, 0] == 0 and (empty.rgb[0, 0] == 0).all()


def test_lambertian_light_and_shadow():
    floor = _wall(2.0, 1)
    lit = Renderer([floor], Shading(lights=(Light((0.0, 0.0, 1.0), 1.0),), ambient=0.2, shadows=True))
    frame = lit.render(_camera())
    # brightest under the light, darker towards the corners (cosine and falloff)
    assert frame.rgb[24, 32, 0] > frame.rgb[0, 0, 0] + 10
    blocker = trimesh.creation.box(extents=(0.4, 0.4, 0.05))
    blocker.apply_translation([0.0, 0.0, 1.5])
    shadowed = Renderer(
        [floor, RenderMesh.uniform(2, blocker.vertices, blocker.faces, (0.5, 0.5, 0.5))],
        Shading(lights=(Light((0.0, 0.0, 1.0), 1.0),), ambient=0.2, shadows=True),
    )
    # a pixel of the floor beside the blocker, in its shadow
    cam = _camera(eye=(0.6, 0.0, 0.0))
    a, b = lit.render(cam), shadowed.render(cam)
    assert b.ids[24, 20] == 1
    assert int(b.rgb[24, 20, 0]) < int(a.rgb[24, 20, 0]) - 10


def test_texture_is_fixed_to_the_surface():
    # a textured plane seen from two positions: the same surface point has the same colour
    plane = _wall(3.0, 1, texture=Texture.WOOD)
    r = Renderer([plane], Shading(lights=(), ambient=1.0, shadows=False))
    a = r.render(_camera())
    b = r.render(_camera(eye=(0.06, 0.0, 0.0)))  # 0.06 m at depth 3 and f = 50: exactly one pixel
    np.testing.assert_array_equal(a.rgb[:, 1:], b.rgb[:, :-1])
    assert a.rgb[..., 0].std() > 1.0


def test_camera_rays_have_unit_z_in_camera_frame():
    cam = _camera()
    origin, dirs = camera_rays(cam)
    assert dirs.shape == (48, 64, 3)
    np.testing.assert_allclose(dirs[..., 2], 1.0)
    np.testing.assert_allclose(origin, 0.0)


def test_bad_input_is_refused():
    with pytest.raises(ValueError):
        Renderer([])
    with pytest.raises(ValueError):
        Renderer([RenderMesh.uniform(1, np.zeros((3, 3)), np.zeros((0, 3), int), (1, 1, 1))])
