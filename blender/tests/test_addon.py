"""The add-on in Blender without a window: run by tests/python.rs as

    ACTIVESKIN_BIN=activeskin blender -b --factory-startup --python test_addon.py -- ADDON_PARENT CACHE SPLASH RENDER

(the add-on copied there with the wheel it unpacks). A cube of particles falls under
gravity: the bake writes a mesh a frame, the display object follows the timeline with a
`velocity` attribute, a bake stopped part-way resumes to the same files, and bad
parameters are one line in Blender's report, no traceback. Then the demo splash (SPLASH,
a frame pattern; written again with ids and velocities, as SPH solvers write them)
baked from files: the shown mesh at three frames is the command's (ACTIVESKIN_BIN), and
its USD shot the command's (`--usd --up z`) byte for byte; the same from a particle system whose point
cache holds the splash's particles (as tools bring an SPH cache into Blender's particles)
and from a mesh object whose points are the frame's particles (as Sequence Loader shows
an SPH cache). With the OpenVDB build: a Mantaflow liquid baked in the scene, skinned
from its domain's cache as `activeskin skin` (ACTIVESKIN_BIN) skins its files, the VDB
skins written, the surface placed where Blender's own liquid mesh is. Frame 16 of the
splash rendered with Cycles, motion blur on, into RENDER (a PNG), not empty.
"""

import importlib
import math
import os
import struct
import subprocess
import sys
import time

import bpy
import numpy as np

addon, cache, splash, render = sys.argv[sys.argv.index("--") + 1 :]
binary = os.environ["ACTIVESKIN_BIN"]
if addon.endswith(".zip"):
    # Blender 4.2+: the zip `make blender-addon` writes, installed as an extension (its
    # wheel installed by Blender from the manifest) into BLENDER_USER_RESOURCES, enabled.
    installed = bpy.ops.extensions.package_install_files(
        filepath=addon, repo="user_default", enable_on_install=True
    )
    assert installed == {"FINISHED"}, installed
    activeskin_blender = importlib.import_module("bl_ext.user_default.activeskin")
    assert hasattr(bpy.types.Scene, "activeskin"), "the extension did not register"
else:
    sys.path.insert(0, addon)
    import activeskin_blender  # noqa: E402

    activeskin_blender.register()
print(f"Blender {bpy.app.version_string}, the add-on from {addon}")
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
# The panel starts at the library's defaults, read as the add-on registered.
library = activeskin_blender._activeskin()
assert (s.alpha, s.smooth) == (library.DEFAULT_ALPHA, library.DEFAULT_PARTICLE_SMOOTHING), (
    s.alpha, s.smooth)
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
    # Said by the panel's label, not as the package's argument or the command's flag.
    assert "Particle radius must be a positive number" in message, message
    assert "Traceback" not in message and len(message.splitlines()) == 1, message
    print(f"bad radius reported: {message}")
else:
    raise AssertionError("a negative radius was baked")

# The demo splash, its particles numbered and their velocities (central differences)
# written beside them, as SPH solvers write theirs.
read = activeskin_blender._activeskin().read_particles
drops = [read(splash.replace("####", f"{f:04d}"))["positions"] for f in range(1, 37)]
assert len({len(p) for p in drops}) == 1, "the splash keeps its particles"
splash = os.path.join(cache, "splash_in", "drop.####.ply")
os.makedirs(os.path.dirname(splash))
for f in range(1, 37):
    before, after = drops[max(f - 2, 0)], drops[min(f, 35)]
    velocity = (after - before) * 24.0 / (min(f, 35) - max(f - 2, 0))
    rows = np.zeros(len(before), [("p", "<f4", 3), ("v", "<f4", 3), ("id", "<i4")])
    rows["p"], rows["v"], rows["id"] = drops[f - 1], velocity, np.arange(len(before))
    header = (
        f"ply\nformat binary_little_endian 1.0\nelement vertex {len(rows)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float vx\nproperty float vy\nproperty float vz\n"
        "property int id\nend_header\n"
    )
    with open(splash.replace("####", f"{f:04d}"), "wb") as out:
        out.write(header.encode() + rows.tobytes())
# The command's meshes and USD shot of it (α = 48, as the demo dresses it), z up.
cli = os.path.join(cache, "cli", "m.{frame:04d}.obj")
cli_usd = os.path.join(cache, "cli", "skin.usda")
subprocess.run(
    [binary, "particles", "--particles", splash, "--radius", "0.04", "--alpha", "48",
     "--mesh", cli.replace("{frame:04d}", "####"), "--usd", cli_usd, "--up", "z", "-q"],
    check=True,
)

# The splash from its PLY files, as the command dresses it.
s.radius = 0.04
s.alpha = 48.0
s.source = "FILES"
s.pattern = splash
s.frame_start, s.frame_end = 1, 36
s.cache_dir = os.path.join(cache, "splash")
s.write_usd = True
assert bpy.ops.activeskin.bake() == {"FINISHED"}
s.write_usd = False
# The USD shot: the stage, its manifest and every frame's layer, the command's.
theirs_usd = os.path.dirname(cli_usd)
usd_files = sorted(
    os.path.relpath(os.path.join(d, f), theirs_usd)
    for d, _, names in os.walk(theirs_usd) for f in names if f.endswith(".usda")
)
assert len(usd_files) == 2 + 36, usd_files
for name in usd_files:
    with open(os.path.join(theirs_usd, name), "rb") as a, \
            open(os.path.join(bpy.path.abspath(s.cache_dir), name), "rb") as b:
        assert a.read() == b.read(), f"{name}: the add-on's USD differs from the command's"
print(f"splash USD shot: {len(usd_files)} files, the command's byte for byte")

# Read back by Blender's own USD importer (built into 4.2+; Debian's 3.4 is built without
# USD): a mesh sequence cache with the command's mesh and a `velocity` attribute a frame.
if bpy.app.build_options.usd:
    before = set(bpy.data.objects)
    assert bpy.ops.wm.usd_import(filepath=os.path.join(bpy.path.abspath(s.cache_dir), "skin.usda")) == {"FINISHED"}
    imported = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    assert len(imported) == 1, imported
    assert [m.type for m in imported[0].modifiers] == ["MESH_SEQUENCE_CACHE"], imported[0].modifiers
    for frame in (6, 16):
        scene.frame_set(frame)
        shown_usd = imported[0].evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        with open(cli.format(frame=frame)) as f:
            theirs = sum(line.startswith("v ") for line in f)
        assert len(shown_usd.vertices) == theirs, (frame, len(shown_usd.vertices), theirs)
        assert "velocity" in shown_usd.attributes, [a.name for a in shown_usd.attributes]
        v = np.empty(3 * len(shown_usd.vertices), np.float32)
        shown_usd.attributes["velocity"].data.foreach_get("vector", v)
        mean = np.linalg.norm(v.reshape(-1, 3), axis=1).mean()
        assert 0.05 < mean < 10.0, (frame, mean)
        print(f"USD import, frame {frame}: {len(shown_usd.vertices)} vertices, velocity {mean:.2f} m/s")
    imported[0].hide_render = True
elif bpy.app.version >= (4, 2, 0):
    raise AssertionError("Blender 4.2+ without USD")


def obj_vertices(path):
    with open(path) as f:
        return [tuple(map(float, line.split()[1:4])) for line in f if line.startswith("v ")]


def check_against_the_command(what, frames=(6, 12, 24)):
    for frame in frames:
        scene.frame_set(frame)
        shown = bpy.data.objects["ActiveSkin"].data
        theirs = obj_vertices(cli.format(frame=frame))
        assert len(shown.vertices) == len(theirs), (what, frame, len(shown.vertices), len(theirs))
        worst = max(
            max(abs(a - b) for a, b in zip(v.co, w)) for v, w in zip(shown.vertices, theirs)
        )
        assert worst < 1e-5, (what, frame, worst)
        print(f"from {what}, frame {frame}: {len(theirs)} vertices, "
              f"at most {worst:.1e} from the command's")


check_against_the_command("its files")

# Cut to a box object's bounds: the command's `--region` meshes, open on the box's sides.
corners = [(x, y, z) for x in (1.0, 1.5) for y in (0.0, 3.0) for z in (1.0, 1.62)]
box = bpy.data.objects.new("region", bpy.data.meshes.new("region"))
box.data.from_pydata(corners, [], [])
scene.collection.objects.link(box)
box.hide_render = True
s.region = box
s.write_usd = False
s.cache_dir = os.path.join(cache, "splash_region")
assert bpy.ops.activeskin.bake() == {"FINISHED"}
whole_cli = cli
cli = os.path.join(cache, "cli_region", "m.{frame:04d}.obj")
subprocess.run(
    [binary, "particles", "--particles", splash, "--radius", "0.04", "--alpha", "48",
     "--region", "1.0,0,1.0,1.5,3,1.62", "--mesh", cli.replace("{frame:04d}", "####"), "-q"],
    check=True,
)
check_against_the_command("its files in a region")
# Open on the box's sides by design: the suite checks these meshes as surfaces with a
# boundary (tests/common's CUT_TO_REGION).
for folder in (s.cache_dir, os.path.dirname(cli)):
    open(os.path.join(bpy.path.abspath(folder), ".cut-to-region"), "w").close()
assert max(v.co.x for v in bpy.data.objects["ActiveSkin"].data.vertices) <= 1.5
cli = whole_cli
s.region = None
s.cache_dir = os.path.join(cache, "splash")

# Meeting colliders: a floor under the splash (a box object, its mesh placed by its
# transform) in a Colliders collection, written into the cache as one OBJ as the bake
# starts, is the command's --collider on that file; moving (keyframed down), one OBJ a
# frame, the command's on their pattern.
BOX_QUADS = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
floor = bpy.data.objects.new("floor", bpy.data.meshes.new("floor"))
floor.data.from_pydata(
    [tuple((1.5, 0.25, 1.5)[a] * (1 if c >> a & 1 else -1) for a in range(3)) for c in range(8)],
    [], BOX_QUADS,
)
floor.location = (1.5, 0.75, 1.5)  # the world's y from 0.5 to 1.0, the splash's floor
colliders = bpy.data.collections.new("colliders")
colliders.objects.link(floor)
scene.collection.children.link(colliders)
floor.hide_render = True
s.colliders = colliders
s.collider_depth = 0.01
for moving in (False, True):
    s.colliders_move = moving
    if moving:
        floor.keyframe_insert("location", frame=1)
        floor.location.y = 0.65
        floor.keyframe_insert("location", frame=36)
    s.cache_dir = os.path.join(cache, "splash_moving_floor" if moving else "splash_floor")
    assert bpy.ops.activeskin.bake() == {"FINISHED"}
    folder = bpy.path.abspath(s.cache_dir)
    written = os.path.join(folder, "collider.####.obj" if moving else "collider.obj")
    corners = np.array(obj_vertices(written.replace("####", "0036") if moving else written))
    top = 0.9 if moving else 1.0
    assert np.allclose(corners.min(0), (0, top - 0.5, 0)) and np.allclose(corners.max(0), (3, top, 3)), corners
    cli = os.path.join(cache, "cli_moving_floor" if moving else "cli_floor", "m.{frame:04d}.obj")
    subprocess.run(
        [binary, "particles", "--particles", splash, "--radius", "0.04", "--alpha", "48",
         "--collider", written, "--collider-depth", "0.01",
         "--mesh", cli.replace("{frame:04d}", "####"), "-q"],
        check=True,
    )
    check_against_the_command("its files meeting a moving floor" if moving else "its files meeting a floor")
    # The floor's face under the splash (no shell off it): down to 0.01 into it.
    scene.frame_set(12)
    lowest = min(v.co.y for v in bpy.data.objects["ActiveSkin"].data.vertices)
    floor_at = floor.matrix_world.translation.y + 0.25
    assert abs(lowest - (floor_at - 0.01)) < 0.01, (moving, lowest, floor_at)
s.colliders = None
cli = whole_cli
s.cache_dir = os.path.join(cache, "splash")

# The live preview: no bake, the surface rebuilt as the frame changes at twice the voxel
# size, carried on while the frames step forward (frame 6 after 1–6 is the command's run
# over 1–6 at that voxel), started again on a jump (frame 20 alone is the command's
# run of frame 20 alone).
s.use_preview = True
s.preview_coarsening = 2.0
voxel = 2.0 * activeskin_blender._activeskin().particle_voxel_size(0.04)
for frames, name in (("1-6", "cli_preview"), ("20-20", "cli_preview_jump")):
    cli = os.path.join(cache, name, "m.{frame:04d}.obj")
    subprocess.run(
        [binary, "particles", "--particles", splash, "--radius", "0.04", "--alpha", "48",
         "--voxel-size", repr(voxel), "--frames", frames,
         "--mesh", cli.replace("{frame:04d}", "####"), "-q"],
        check=True,
    )
steps = []
for frame in range(1, 7):
    started = time.perf_counter()
    scene.frame_set(frame)
    steps.append(time.perf_counter() - started)
cli = os.path.join(cache, "cli_preview", "m.{frame:04d}.obj")
check_against_the_command("the live preview stepped from 1", frames=(6,))
print("preview frame steps: " + ", ".join(f"{1e3 * t:.0f} ms" for t in steps))
scene.frame_set(20)
cli = os.path.join(cache, "cli_preview_jump", "m.{frame:04d}.obj")
check_against_the_command("the live preview jumped to 20", frames=(20,))
# Meeting the floor: the preview writes the Colliders beside the cache as it starts
# (a jump to 10) and meets them as the command does at its voxel.
s.colliders, s.colliders_move = colliders, False
scene.frame_set(10)
written = os.path.join(bpy.path.abspath(s.cache_dir), "preview_collider.obj")
cli = os.path.join(cache, "cli_preview_floor", "m.{frame:04d}.obj")
subprocess.run(
    [binary, "particles", "--particles", splash, "--radius", "0.04", "--alpha", "48",
     "--voxel-size", repr(voxel), "--frames", "10-10", "--collider", written,
     "--collider-depth", "0.01", "--mesh", cli.replace("{frame:04d}", "####"), "-q"],
    check=True,
)
check_against_the_command("the live preview meeting a floor", frames=(10,))
s.colliders = None
s.use_preview = False
cli = whole_cli

# The splash as a particle system of the scene: its point cache, external, holds each
# frame's particles (Blender's .bphys: "BPHYSICS", the type, the particle count, the data
# kept — index, location, velocity — then each particle's), as tools that bring an SPH
# cache into Blender's particles write it.
bphys = os.path.join(cache, "bphys")
os.makedirs(bphys)
PARTICLES, INDEX, LOCATION, VELOCITY = 1, 1 << 0, 1 << 1, 1 << 2
count = len(drops[0])
for frame in range(0, 37):
    body = b""  # frame 0: the count alone (Blender's info file)
    if frame:
        f = read(splash.replace("####", f"{frame:04d}"))
        rows = np.zeros(count, [("i", "<u4"), ("p", "<f4", 3), ("v", "<f4", 3)])
        rows["i"], rows["p"], rows["v"] = f["ids"], f["positions"], f["velocities"]
        body = rows.tobytes()
    with open(os.path.join(bphys, f"splash_{frame:06d}_00.bphys"), "wb") as out:
        out.write(b"BPHYSICS" + struct.pack("<III", PARTICLES, count, INDEX | LOCATION | VELOCITY) + body)
holder = bpy.data.objects.new("splash_particles", bpy.data.meshes.new("splash_particles"))
holder.data.from_pydata([(0, 0, 0)], [], [])
scene.collection.objects.link(holder)
holder.modifiers.new("particles", "PARTICLE_SYSTEM")
system = holder.particle_systems[0]
system.settings.count = count
system.settings.frame_start = system.settings.frame_end = 1
system.settings.lifetime = 1000
cache_of = system.point_cache
cache_of.use_external = True
cache_of.filepath = bphys
cache_of.name = "splash"
cache_of.index = 0
s.source = "PARTICLES"
s.emitter = holder
s.particle_system = ""
s.cache_dir = os.path.join(cache, "splash_particles")
assert bpy.ops.activeskin.bake() == {"FINISHED"}
check_against_the_command("a particle system")
holder.hide_render = True

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
for name in ("velocity", "id"):
    splash_mesh.attributes.remove(splash_mesh.attributes[name])
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



def alpha(image):
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    return pixels[3::4]


blurred = alpha(image)
covered = float((blurred > 0.5).mean())
assert covered > 0.01, covered
print(f"rendered frame 16: the surface covers {100 * covered:.1f} % of the image")
# The same frame without motion blur: the blur (from the mesh's `velocity`) smears the
# moving splash's edges, so more pixels are partly covered.
scene.render.use_motion_blur = False
scene.render.filepath = render.replace(".png", "_sharp.png")
bpy.ops.render.render(write_still=True)
sharp = alpha(bpy.data.images.load(scene.render.filepath))
partial = [int(((a > 0.05) & (a < 0.95)).sum()) for a in (blurred, sharp)]
print(f"partly covered pixels: {partial[0]} blurred, {partial[1]} sharp")
assert partial[0] > 1.3 * partial[1], partial
scene.render.use_motion_blur = True

# A Mantaflow liquid baked in the scene (a ball dropped into a pool, 32 cells, 8 frames),
# skinned from its domain's OpenVDB cache: the command's meshes and VDB skins, the surface
# where Blender's own liquid mesh is.
activeskin = activeskin_blender._activeskin()
if not activeskin.HAS_VDB:
    print("Mantaflow: skipped, this activeskin was built without OpenVDB")
else:
    manta = os.path.join(cache, "manta")
    scene.frame_start, scene.frame_end = 1, 8
    # The Mantaflow example's scene (docs/guide.md), smaller, beside the others, with Blender's
    # own liquid mesh to compare the skin's place with.
    examples = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples")
    sys.path.insert(0, examples)
    from mantaflow_bake import drop_into_pool  # noqa: E402

    domain = drop_into_pool(manta, resolution=32, frames=8, at=(4.0, 0.0, 0.0), mesh=True)
    pattern = os.path.join(manta, "data", "fluid_data_####.vdb")
    assert os.path.isfile(pattern.replace("####", "0008")), os.listdir(manta)

    s.source = "MANTAFLOW"
    s.emitter = domain
    s.alpha = 4.0
    s.frame_start, s.frame_end = 1, 8
    s.cache_dir = os.path.join(cache, "manta_skin")
    s.write_vdb = True
    assert bpy.ops.activeskin.bake() == {"FINISHED"}
    theirs = os.path.join(cache, "cli_manta")
    subprocess.run(
        [binary, "skin", "--target", pattern, "--mesh", os.path.join(theirs, "m.####.obj"),
         "--out", os.path.join(theirs, "s.####.vdb"), "-q"],
        check=True,
    )
    cli = os.path.join(theirs, "m.{frame:04d}.obj")
    check_against_the_command("a Mantaflow domain", frames=(3, 6, 8))
    for frame in (3, 8):
        # The same bytes but the random UUID after the file's 21-byte header.
        with open(os.path.join(theirs, f"s.{frame:04d}.vdb"), "rb") as a, \
                open(os.path.join(bpy.path.abspath(s.cache_dir), f"skin_{frame:04d}.vdb"), "rb") as b:
            a, b = a.read(), b.read()
            assert a[:21] + a[57:] == b[:21] + b[57:], f"frame {frame}: the add-on's VDB differs from the command's"
    print("Mantaflow: the VDB skins (surface and v) the command's")

    # Placed where Blender shows the liquid: its own mesh of the cache (smoothed,
    # at twice the resolution) and the skin's bounds agree within a cell and a half.
    scene.frame_set(8)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    blenders = domain.evaluated_get(depsgraph)

    def bounds(obj):
        m = obj.matrix_world
        points = np.array([tuple(m @ v.co) for v in obj.data.vertices])
        return points.min(axis=0), points.max(axis=0)

    (lo_b, hi_b), (lo_s, hi_s) = bounds(blenders), bounds(bpy.data.objects["ActiveSkin"])
    dx = 2.0 / 32
    off = max(np.abs(lo_b - lo_s).max(), np.abs(hi_b - hi_s).max()) / dx
    print(f"Mantaflow frame 8: the skin's bounds within {off:.2f} cells of Blender's liquid mesh")
    assert off < 1.5, (lo_b, hi_b, lo_s, hi_s)

    # Tension off (a clean cache): the command's `--beta 0`, not its default.
    s.use_tension = False
    s.write_vdb = False
    s.cache_dir = os.path.join(cache, "manta_untensed")
    assert bpy.ops.activeskin.bake() == {"FINISHED"}
    theirs = os.path.join(cache, "cli_manta_untensed")
    subprocess.run(
        [binary, "skin", "--target", pattern, "--mesh", os.path.join(theirs, "m.####.obj"),
         "--beta", "0", "-q"],
        check=True,
    )
    cli = os.path.join(theirs, "m.{frame:04d}.obj")
    check_against_the_command("a Mantaflow domain without tension", frames=(3, 8))
    tensed = obj_vertices(os.path.join(cache, "cli_manta", "m.0008.obj"))
    assert tensed != obj_vertices(cli.format(frame=8)), "--beta 0 made the default's surface"
    s.use_tension = True

print("ADDON OK")
