"""The add-on in Blender without a window: run by tests/python.rs as

    blender -b --factory-startup --python test_addon.py -- ADDON_PARENT CACHE SPLASH CLI RENDER

(the add-on copied there with the wheel it unpacks). A cube of particles falls under
gravity: the bake writes a mesh a frame, the display object follows the timeline with a
`velocity` attribute, a bake stopped part-way resumes to the same files, and bad
parameters are one line in Blender's report, no traceback. Then the demo splash's PLY
sequence (SPLASH, a frame pattern) baked from files: the shown mesh at three frames is
the command's (CLI, an OBJ pattern with {frame:04d}), and the same from a mesh object
whose points are the frame's particles (as Sequence Loader shows an SPH cache); frame 16
rendered with Cycles,
motion blur on, into RENDER (a PNG), not empty.
"""

import math
import os
import sys

import bpy
import numpy as np

parent, cache, splash, cli, render = sys.argv[sys.argv.index("--") + 1 :]
sys.path.insert(0, parent)
import activeskin_blender  # noqa: E402

activeskin_blender.register()
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 8

mesh = bpy.data.meshes.new("emitter")
half = 0.5
mesh.from_pydata(
    [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)],
    [],
    [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)],
)
emitter = bpy.data.objects.new("emitter", mesh)
scene.collection.objects.link(emitter)
emitter.modifiers.new("particles", "PARTICLE_SYSTEM")
ps = emitter.particle_systems[0].settings
ps.count = 3000
ps.frame_start = ps.frame_end = 1
ps.lifetime = 1000
ps.emit_from = "VOLUME"
ps.distribution = "JIT"
ps.normal_factor = 0.0
emitter.show_instancer_for_render = False

s = scene.activeskin
s.source = "PARTICLES"
s.emitter = emitter
s.radius = 0.035
s.frame_start, s.frame_end = 1, 8
s.cache_dir = cache

result = bpy.ops.activeskin.bake()
assert result == {"FINISHED"}, result
files = sorted(os.listdir(cache))
assert files == [f"skin_{f:04d}.ply" for f in range(1, 9)], files

scene.frame_set(6)
shown = bpy.data.objects["ActiveSkin"].data
assert len(shown.vertices) > 500, len(shown.vertices)
assert len(shown.polygons) > 1000
velocity = shown.attributes["velocity"]
assert len(velocity.data) == len(shown.vertices)
mean_vz = sum(v.vector.z for v in velocity.data) / len(velocity.data)
# Falling under gravity for a quarter of a second: about -2 m/s.
assert -4.0 < mean_vz < -0.5, mean_vz
print(f"frame 6: {len(shown.vertices)} vertices, mean velocity z {mean_vz:.2f} m/s")

# Stopped after frame 6: baking again resumes and writes the same frames 7 and 8.
before = {f: open(os.path.join(cache, f"skin_{f:04d}.ply"), "rb").read() for f in (7, 8)}
for f in (7, 8):
    os.remove(os.path.join(cache, f"skin_{f:04d}.ply"))
assert bpy.ops.activeskin.bake() == {"FINISHED"}
for f in (7, 8):
    again = open(os.path.join(cache, f"skin_{f:04d}.ply"), "rb").read()
    assert again == before[f], f"frame {f} differs after the resume"
print("resumed: frames 7 and 8 the same")

s.radius = -1.0
try:
    bpy.ops.activeskin.bake()
except RuntimeError as e:
    message = str(e).strip()
    assert "radius must be a positive number" in message, message
    assert "Traceback" not in message and len(message.splitlines()) == 1, message
    print(f"bad radius reported: {message}")
else:
    raise AssertionError("a negative radius was baked")

# The demo splash from its PLY files, as the command dresses it (α = 48).
s.radius = 0.04
s.alpha = 48.0
s.source = "FILES"
s.pattern = splash
s.frame_start, s.frame_end = 1, 36
s.cache_dir = os.path.join(cache, "splash")
assert bpy.ops.activeskin.bake() == {"FINISHED"}


def obj_vertices(path):
    with open(path) as f:
        return [tuple(map(float, line.split()[1:4])) for line in f if line.startswith("v ")]


def check_against_the_command(what):
    for frame in (6, 12, 24):
        scene.frame_set(frame)
        shown = bpy.data.objects["ActiveSkin"].data
        theirs = obj_vertices(cli.format(frame=frame))
        assert len(shown.vertices) == len(theirs), (what, frame, len(shown.vertices), len(theirs))
        worst = max(
            max(abs(a - b) for a, b in zip(v.co, w)) for v, w in zip(shown.vertices, theirs)
        )
        assert worst < 1e-5, (what, frame, worst)
        print(f"splash from {what}, frame {frame}: {len(theirs)} vertices, "
              f"at most {worst:.1e} from the command's")


check_against_the_command("its files")

# The splash in the scene: a mesh object whose points are each frame's particles, with
# their `velocity` and `id` point attributes, as Sequence Loader brings an SPH cache into
# Blender (a frame handler loading the frame's file).
splash_mesh = bpy.data.meshes.new("splash")
splash_object = bpy.data.objects.new("splash", splash_mesh)
scene.collection.objects.link(splash_object)


def load_splash(scene, *args):
    read = activeskin_blender._activeskin().read_particles(splash.replace("####", f"{scene.frame_current:04d}"))
    p, v, ids = read["positions"], read["velocities"], read["ids"]
    splash_mesh.clear_geometry()
    for name in ("velocity", "id"):
        if name in splash_mesh.attributes:
            splash_mesh.attributes.remove(splash_mesh.attributes[name])
    splash_mesh.vertices.add(len(p))
    # Stored relative to the object, so that its transform puts them back.
    splash_mesh.vertices.foreach_set("co", p.ravel())
    # As in the files: velocities and ids where the frame has them.
    if v is not None:
        splash_mesh.attributes.new("velocity", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", v.ravel())
    if ids is not None:
        splash_mesh.attributes.new("id", "INT", "POINT").data.foreach_set("value", ids.astype(np.int32))
    splash_mesh.update()


bpy.app.handlers.frame_change_pre.append(load_splash)
s.source = "POINTS"
s.emitter = splash_object
s.cache_dir = os.path.join(cache, "splash_points")
assert bpy.ops.activeskin.bake() == {"FINISHED"}
check_against_the_command("a mesh object's points")
# The points are read in world space (moved and turned by the object's transform), with
# their velocity (turned) and id attributes.
scene.frame_set(12)
splash_object.location = (2.0, -1.0, 0.5)
splash_object.rotation_euler = (0.0, 0.0, math.pi / 2)
n = len(splash_mesh.vertices)
splash_mesh.attributes.new("velocity", "FLOAT_VECTOR", "POINT").data.foreach_set(
    "vector", np.tile(np.float32([1, 2, 3]), n))
splash_mesh.attributes.new("id", "INT", "POINT").data.foreach_set(
    "value", np.arange(n, dtype=np.int32)[::-1].copy())
bpy.context.view_layer.update()
p, v, ids = activeskin_blender._points_of(s, bpy.context.evaluated_depsgraph_get())
local = activeskin_blender._activeskin().read_particles(splash.replace("####", "0012"))
turned = local["positions"][:, [1, 0, 2]] * [-1, 1, 1] + [2.0, -1.0, 0.5]
assert np.abs(p - turned).max() < 1e-5, np.abs(p - turned).max()
assert np.abs(v - [-2, 1, 3]).max() < 1e-5, v[:3]
assert ids.dtype == np.int64 and (ids == np.arange(n)[::-1]).all()
print("a mesh object's points: read in world space, with velocity and id")
bpy.app.handlers.frame_change_pre.remove(load_splash)
splash_object.hide_render = True

# Frame 16 with Cycles, motion blur on: the data's y is up, Blender's z.

skin = bpy.data.objects["ActiveSkin"]
skin.rotation_euler = (math.pi / 2, 0, 0)
material = bpy.data.materials.new("water")
material.diffuse_color = (0.05, 0.25, 0.8, 1)
skin.data.materials.append(material)
target = bpy.data.objects.new("target", None)
target.location = (1.5, -1.5, 1.25)
scene.collection.objects.link(target)
camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
camera.location = (3.3, -4.2, 2.3)
track = camera.constraints.new("TRACK_TO")
track.target = target
scene.collection.objects.link(camera)
scene.camera = camera
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.rotation_euler = (0.6, 0.3, 0.8)
scene.collection.objects.link(sun)
scene.render.engine = "CYCLES"
scene.cycles.samples = 16
scene.cycles.device = "CPU"
scene.cycles.use_denoising = False
for other in scene.objects:
    if other.name not in ("ActiveSkin", "camera", "sun", "target"):
        other.hide_render = True
scene.render.use_motion_blur = True
scene.render.film_transparent = True
scene.render.resolution_x, scene.render.resolution_y = 480, 270
scene.render.resolution_percentage = 100
scene.render.filepath = render
scene.frame_set(16)
bpy.ops.render.render(write_still=True)
image = bpy.data.images.load(render)

pixels = np.empty(len(image.pixels), np.float32)
image.pixels.foreach_get(pixels)
covered = float((pixels[3::4] > 0.5).mean())
assert covered > 0.01, covered
print(f"rendered frame 16: the surface covers {100 * covered:.1f} % of the image")
print("ADDON OK")
