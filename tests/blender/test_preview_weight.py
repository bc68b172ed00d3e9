"""The viewport preview lights only what the projector's light reaches, weighted as that light falls (cos of the
incidence over distance squared); the projector's spot cone holds its whole frame and is drawn to the object."""
import math

import bpy
import numpy as np
import pytest
from mathutils import Vector

SIZE = (96, 72)


def _white(name="white"):
    image = bpy.data.images.new(name, 16, 12, float_buffer=True)
    image.pixels.foreach_set(np.ones(16 * 12 * 4, np.float32))
    return image


def _projector(scene, location, throw_ratio=0.8, shift=(0.0, 0.0), size=(160, 120)):
    """A LAPIG projector at `location` looking along +Y (up +Z), projecting white."""
    from lapig.lapig_addon.blender import projector_nodes, rig

    projector = rig.create_projector(scene)
    p = projector.lapig_projector
    p.resolution_x, p.resolution_y = size
    p.throw_ratio, (p.shift_x, p.shift_y) = throw_ratio, shift
    projector.location, projector.rotation_euler = location, (math.pi / 2, 0.0, 0.0)
    projector_nodes.set_projected_image(projector.data, _white())
    bpy.context.view_layer.update()
    return projector


def _camera(scene, location, look_at=(0.0, 0.0, 0.0), lens=35.0):
    cam = bpy.data.objects.new("view", bpy.data.cameras.new("view"))
    scene.collection.objects.link(cam)
    cam.data.lens, cam.data.sensor_fit, cam.data.sensor_width = lens, "HORIZONTAL", 36.0
    cam.location = location
    cam.rotation_euler = (Vector(look_at) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    bpy.context.view_layer.update()
    return cam


def _render(scene, camera, path, samples=4):
    """Linear Cycles render from `camera`, (H, W, 3), rows top-down."""
    scene.camera = camera
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = *SIZE, 100
    scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.max_bounces = samples, False, 0
    scene.view_settings.view_transform = "Standard"
    r.image_settings.file_format = "OPEN_EXR"
    r.filepath = str(path)
    bpy.ops.render.render(write_still=True, scene=scene.name)
    image = bpy.data.images.load(str(path))
    w, h = image.size
    px = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(px)
    bpy.data.images.remove(image)
    return px.reshape(h, w, 4)[::-1, :, :3]


def _at(pixels, scene, camera, points):
    """The render's value at world points (3x3 pixel mean around each one's projection)."""
    from lapig.lapig_addon.blender.geometry_probe import CameraProjection

    xy = np.rint(CameraProjection(camera, scene, *SIZE).project(np.asarray(points, float))).astype(int)
    return np.array([pixels[y - 1:y + 2, x - 1:x + 2].mean() for x, y in xy])


def _show_the_weight(material):
    """The preview material's projected colour (the image times its weight, which multiplies the base colour)
    straight to the output as emission, so a render reads the weight itself."""
    tree = material.node_tree
    mix = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeMix" and n.blend_type == "MULTIPLY")
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(mix.inputs["B"].links[0].from_socket, emission.inputs["Color"])
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(emission.outputs[0], output.inputs["Surface"])


def _face_materials(obj):
    """The evaluated mesh's material name on the face through each axis direction: what Solid mode draws."""
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    names = {}
    for polygon in mesh.polygons:
        axis = tuple(int(round(c)) for c in polygon.normal)
        material = mesh.materials[polygon.material_index]
        names[axis] = material.name if material else ""
    return names


def _light_weight(projector_location, point, normal, focus):
    to_projector = np.asarray(projector_location, float) - np.asarray(point, float)
    distance = np.linalg.norm(to_projector)
    return max(float(np.dot(normal, to_projector / distance)), 0.0) * (focus / distance) ** 2


@pytest.mark.blender
@pytest.mark.parametrize("height", [0.0, 0.9])  # level with the cube's centre; above its top (grazing there)
def test_the_preview_lights_what_the_projector_reaches_as_its_light_would(lapig_registered, tmp_path, height):
    from lapig.lapig_addon.blender import demo_scene, preview, solid_reach

    scene = demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    surface = bpy.data.materials.new("grey surface")
    cube.data.materials.append(surface)
    nodes_before = sorted((n.bl_idname, n.name) for n in surface.node_tree.nodes)
    links_before = len(surface.node_tree.links)
    location = (0.0, -3.0, height)
    projector = _projector(scene, location)
    projector.lapig_projector.focus_distance = 2.5  # the front face's distance: 1 at its centre, level with it
    preview.enable_preview(cube, projector, bpy.data.images["white"])
    _show_the_weight(cube.material_slots[0].material)
    projector.hide_render = True  # the render shows the preview material alone
    camera = _camera(scene, (2.2, -3.2, 2.4))
    pixels = _render(scene, camera, tmp_path / f"weight_{height}.exr")

    samples = {  # point, its face's normal
        "front centre": ((0.0, -0.5, 0.0), (0, -1, 0)), "front off centre": ((0.3, -0.5, 0.1), (0, -1, 0)),
        "top": ((0.0, 0.0, 0.5), (0, 0, 1)), "right side": ((0.5, 0.0, 0.1), (1, 0, 0)),
    }
    seen = dict(zip(samples, _at(pixels, scene, camera, [p for p, _ in samples.values()])))
    expected = {name: _light_weight(location, p, n, 2.5) for name, (p, n) in samples.items()}
    print("height", height, {k: (round(float(seen[k]), 3), round(expected[k], 3)) for k in samples})
    for name in samples:
        assert seen[name] == pytest.approx(expected[name], abs=0.03), name
    assert seen["right side"] < 0.01  # a face turned away from the projector gets nothing
    if height == 0.0:
        assert seen["front centre"] == pytest.approx(1.0, abs=0.03) and seen["top"] < 0.01
    else:
        assert 0.03 < seen["top"] < 0.2  # grazing: dim, not the full image stretched over it

    # Solid mode draws the projected UV map's image on every face it is given: the faces the projector cannot
    # reach get the black 'not reached' material instead, the others keep the preview's
    shown = cube.material_slots[0].material.name
    faces = _face_materials(cube)
    assert faces[(0, -1, 0)] == shown and faces[(1, 0, 0)] == faces[(0, 1, 0)] == solid_reach.UNREACHED_MATERIAL
    assert faces[(0, 0, 1)] == (shown if height > 0.5 else solid_reach.UNREACHED_MATERIAL)

    # the preview follows the projector: moved to the cube's right, the right side is lit and the front is not
    projector.location, projector.rotation_euler = (3.0, 0.0, 0.0), (math.pi / 2, 0.0, math.pi / 2)
    bpy.context.view_layer.update()
    moved = _at(_render(scene, camera, tmp_path / f"moved_{height}.exr"), scene, camera,
                [samples["front centre"][0], samples["right side"][0]])
    assert moved[0] < 0.01 and moved[1] > 0.5
    faces = _face_materials(cube)
    assert faces[(1, 0, 0)] == shown and faces[(0, -1, 0)] == solid_reach.UNREACHED_MATERIAL

    # Original: the user's material is back exactly as it was, no preview material (nor its drivers) is left
    preview.disable_preview(cube)
    assert cube.material_slots[0].material == surface and not surface.use_fake_user
    assert sorted((n.bl_idname, n.name) for n in surface.node_tree.nodes) == nodes_before
    assert len(surface.node_tree.links) == links_before and surface.node_tree.animation_data is None
    assert [m.name for m in bpy.data.materials] == ["grey surface"] and not cube.modifiers
    assert not bpy.data.node_groups and set(_face_materials(cube).values()) == {"grey surface"}


@pytest.mark.blender
def test_with_several_projectors_a_face_any_of_them_reaches_keeps_the_preview(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import demo_scene, preview, solid_reach

    scene = demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    front = _projector(scene, (0.0, -3.0, 0.0))
    right = _projector(scene, (3.0, 0.0, 0.0))
    right.rotation_euler = (math.pi / 2, 0.0, math.pi / 2)
    front.lapig_projector.focus_distance = right.lapig_projector.focus_distance = 2.5
    bpy.context.view_layer.update()
    preview.enable_casts(cube, [(front, bpy.data.images["white"]), (right, bpy.data.images["white"])])
    faces = _face_materials(cube)
    shown = cube.material_slots[0].material.name
    assert faces[(0, -1, 0)] == faces[(1, 0, 0)] == shown
    assert faces[(0, 0, 1)] == faces[(-1, 0, 0)] == faces[(0, 1, 0)] == solid_reach.UNREACHED_MATERIAL
    # Material Preview: each face lit by its own projector's weight, the two added
    _show_the_weight(cube.material_slots[0].material)
    front.hide_render = right.hide_render = True
    camera = _camera(scene, (2.2, -3.2, 2.4))
    points = [(0.1, -0.5, 0.1), (0.5, -0.2, 0.1)]
    seen = _at(_render(scene, camera, tmp_path / "two.exr"), scene, camera, points)
    expected = [_light_weight(front.location, points[0], (0, -1, 0), 2.5),
                _light_weight(right.location, points[1], (1, 0, 0), 2.5)]
    assert seen == pytest.approx(expected, abs=0.03)


@pytest.mark.blender
def test_an_appearance_cast_is_masked_by_visibility_not_weighted_again(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import demo_scene, preview

    scene = demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    projector = _projector(scene, (0.0, -3.0, 0.9))
    preview.enable_preview(cube, projector, bpy.data.images["white"], appearance=True)
    projector.hide_render = True
    camera = _camera(scene, (2.2, -3.2, 2.4))
    seen = _at(_render(scene, camera, tmp_path / "appearance.exr"), scene, camera,
               [(0.3, -0.5, 0.1), (0.0, 0.0, 0.5), (0.5, 0.0, 0.1)])
    assert seen[0] == pytest.approx(1.0, abs=0.03) and seen[1] == pytest.approx(1.0, abs=0.03)  # as it is
    assert seen[2] < 0.01  # the face the projector cannot see shows nothing


@pytest.mark.blender
def test_the_spot_cone_lights_every_corner_of_a_shifted_frame(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import demo_scene
    from lapig.lapig_addon.blender.scene_state import projector_model
    from lapig.lapig_core.optics import projector_cone

    scene = demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_plane_add(size=30.0, location=(0.0, 3.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0))
    projector = _projector(scene, (0.0, 0.0, 0.0), throw_ratio=1.2, shift=(0.3, -0.2), size=(160, 100))
    projector.data.energy = 1000.0
    model = projector_model(projector)
    assert projector.data.spot_size == pytest.approx(projector_cone.spot_size(model), abs=1e-6)
    assert math.degrees(projector.data.spot_size) < 90  # not the near-180-degree cone drawn across the viewport
    camera = _camera(scene, (0.0, -0.01, 0.0), look_at=(0.0, 3.0, 0.0), lens=10.0)
    inset = 0.04  # of the frame, inside each corner
    uv = np.array([[inset, inset], [1 - inset, inset], [inset, 1 - inset], [1 - inset, 1 - inset], [0.5, 0.5]])
    sx, sy = model.uv_scale()
    local = np.stack([(uv[:, 0] - 0.5 - model.shift_x) / sx, (uv[:, 1] - 0.5 - model.shift_y) / sy,
                      -np.ones(len(uv))], axis=1)
    world = local @ np.array(projector.matrix_world)[:3, :3].T
    points = world * (3.0 / world[:, 1:2])  # on the wall y = 3

    seen = _at(_render(scene, camera, tmp_path / "cone.exr"), scene, camera, points)
    # the fitted cone changes nothing inside the frame: every corner as lit as under the widest cone
    projector.data.spot_size = projector_cone.LARGEST_SPOT
    widest = _at(_render(scene, camera, tmp_path / "widest.exr"), scene, camera, points)
    print("corners and centre", seen, "under the widest cone", widest)
    assert seen[4] > 0.05 and np.all(widest[:4] > 0.1 * seen[4])
    assert seen == pytest.approx(widest, rel=1e-3)

    # the render does see the cone: one narrower than the frame's farthest corner leaves that corner dark
    projector.data.spot_size = 2 * (projector_cone.corner_half_angle(model) - math.radians(6))
    narrow = _at(_render(scene, camera, tmp_path / "narrow.exr"), scene, camera, points)
    farthest = np.argmax(np.linalg.norm(local[:4, :2], axis=1))
    assert narrow[farthest] < 0.02 * seen[4] and narrow[4] == pytest.approx(seen[4], rel=1e-3)


@pytest.mark.blender
def test_the_drawn_cone_ends_past_the_object_for_every_projector_of_the_rig(lapig_registered):
    from lapig.lapig_addon.blender import demo_scene, scene_state
    from lapig.lapig_addon.blender.scene_state import projector_model
    from lapig.lapig_core.optics import projector_cone

    demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    cube.select_set(True)
    assert bpy.ops.lapig.add_rig() == {"FINISHED"}
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    projectors = scene_state.rig_projectors(bpy.context.scene)
    assert len(projectors) == 2
    corners = np.array([tuple(cube.matrix_world @ Vector(c)) for c in cube.bound_box])
    for projector in projectors:
        light = projector.data
        farthest = np.linalg.norm(corners - np.array(projector.matrix_world.translation), axis=1).max()
        assert farthest < light.cutoff_distance <= 1.2 * farthest  # the drawn cone ends just past the cube
        assert not light.use_custom_distance  # the light itself is not cut there
        assert light.spot_size == pytest.approx(projector_cone.spot_size(projector_model(projector)), abs=1e-6)
