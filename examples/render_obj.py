"""Renders one OBJ mesh (y up) of the SPlisHSPlasH dam break tank with Cycles, through Blender
as a Python module (`pip install bpy==4.5.*` into a CPython 3.11 venv):

    python examples/render_obj.py -- mesh.obj out.png [CAMERA TARGET]

CAMERA and TARGET are Blender points `x,y,z` (the OBJ's y up becomes Blender's z, its z
becomes -y); by default the dam break tank's view. The double dam break's pictures
(data/pictures/double_dam_break_look.*.png) use `1.5,-1.75,1.25 0.4,-0.4,0.22`.

The README's dam break pictures (data/pictures/dam_break_look.*.png) are three of these
side by side: activeskin at its defaults, with --smooth 0, and smoothed splashsurf."""

import bpy, sys, math
args = sys.argv[sys.argv.index("--") + 1:]
obj_path, out = args[0], args[1]
point = lambda text: tuple(float(c) for c in text.split(","))
camera, target = (point(args[2]), point(args[3])) if len(args) >= 4 else (
    (1.25, -1.35, 0.85), (0.5, -0.25, 0.12))
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
bpy.ops.wm.obj_import(filepath=obj_path, forward_axis='NEGATIVE_Z', up_axis='Y')
ob = bpy.context.selected_objects[0]
for p in ob.data.polygons: p.use_smooth = True
mat = bpy.data.materials.new("m"); mat.use_nodes = True
b = mat.node_tree.nodes["Principled BSDF"]; b.inputs["Base Color"].default_value = (0.6, 0.75, 0.9, 1); b.inputs["Roughness"].default_value = 0.15
ob.data.materials.append(mat)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam")); sc.collection.objects.link(cam); sc.camera = cam
cam.location = camera
tgt = bpy.data.objects.new("tgt", None); sc.collection.objects.link(tgt); tgt.location = target
c = cam.constraints.new('TRACK_TO'); c.target = tgt; c.track_axis = 'TRACK_NEGATIVE_Z'; c.up_axis = 'UP_Y'; cam.data.lens = 32
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN")); sc.collection.objects.link(sun)
sun.rotation_euler = (math.radians(40), math.radians(20), math.radians(30)); sun.data.energy = 3
w = bpy.data.worlds.new("w"); sc.world = w; w.use_nodes = True; w.node_tree.nodes["Background"].inputs[1].default_value = 0.6
sc.render.engine = 'CYCLES'; sc.cycles.samples = 24; sc.cycles.device = 'CPU'
sc.render.resolution_x = 720; sc.render.resolution_y = 480; sc.render.filepath = out
bpy.ops.render.render(write_still=True)
