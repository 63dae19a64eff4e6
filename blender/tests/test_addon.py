"""The add-on in Blender without a window: run by tests/python.rs as

    blender -b --factory-startup --python test_addon.py -- ADDON_PARENT CACHE

(the add-on copied there with the wheel it unpacks). A cube of particles falls under
gravity: the bake writes a mesh a frame, the display object follows the timeline with a
`velocity` attribute, a bake stopped part-way resumes to the same files, and bad
parameters are one line in Blender's report, no traceback.
"""

import os
import sys

import bpy

parent, cache = sys.argv[sys.argv.index("--") + 1 :]
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
print("ADDON OK")
