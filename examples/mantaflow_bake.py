# Used for the figures in the README's "Simulation caches" section.
# A ball of liquid dropped into a pool, baked by Mantaflow to OpenVDB (Blender, headless):
# blender -b --python examples/mantaflow_bake.py -- OUT_FOLDER
import bpy
import sys

out = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/work/exp/manta/cache"
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.frame_start = 1
scene.frame_end = 30

bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 1))
domain = bpy.context.object
mod = domain.modifiers.new("Fluid", "FLUID")
mod.fluid_type = "DOMAIN"
s = mod.domain_settings
s.domain_type = "LIQUID"
s.resolution_max = 64
s.cache_directory = out
s.cache_type = "ALL"
s.cache_data_format = "OPENVDB"
s.cache_frame_start = 1
s.cache_frame_end = 30
s.use_mesh = False
s.cache_resumable = True

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(0, 0, 1.45))
ball = bpy.context.object
m = ball.modifiers.new("Fluid", "FLUID")
m.fluid_type = "FLOW"
m.flow_settings.flow_type = "LIQUID"
m.flow_settings.flow_behavior = "GEOMETRY"

bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 0.25))
pool = bpy.context.object
pool.scale = (0.97, 0.97, 0.125)
m = pool.modifiers.new("Fluid", "FLUID")
m.fluid_type = "FLOW"
m.flow_settings.flow_type = "LIQUID"
m.flow_settings.flow_behavior = "GEOMETRY"

bpy.context.view_layer.objects.active = domain
domain.select_set(True)
with bpy.context.temp_override(object=domain, active_object=domain):
    bpy.ops.fluid.bake_all()
print("baked into", out)
