# Used for the figures in docs/guide.md's "Simulation caches" section, and by the Blender
# add-on's test (drop_into_pool). A ball of liquid dropped into a pool, baked by
# Mantaflow to OpenVDB (Blender, headless):
# blender -b --python examples/mantaflow_bake.py -- OUT_FOLDER
import sys

import bpy


def drop_into_pool(out, resolution=64, frames=30, at=(0.0, 0.0, 0.0), mesh=False):
    """Adds to the scene a liquid domain (a 2-unit cube, its floor at `at`) caching into
    `out` in OpenVDB, resumable (Blender keeps `phi` only then), a ball of liquid above a
    pool, and bakes `frames` frames at `resolution` cells (with Blender's own liquid mesh
    when `mesh`). Returns the domain object."""
    x, y, z = at
    bpy.ops.mesh.primitive_cube_add(size=2, location=(x, y, z + 1))
    domain = bpy.context.object
    mod = domain.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "DOMAIN"
    s = mod.domain_settings
    s.domain_type = "LIQUID"
    s.resolution_max = resolution
    s.cache_directory = out
    s.cache_type = "ALL"
    s.cache_data_format = "OPENVDB"
    s.cache_frame_start = 1
    s.cache_frame_end = frames
    s.use_mesh = mesh
    s.cache_resumable = True

    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(x, y, z + 1.45))
    ball = bpy.context.object
    bpy.ops.mesh.primitive_cube_add(size=2, location=(x, y, z + 0.25))
    pool = bpy.context.object
    pool.scale = (0.97, 0.97, 0.125)
    for flow in (ball, pool):
        m = flow.modifiers.new("Fluid", "FLUID")
        m.fluid_type = "FLOW"
        m.flow_settings.flow_type = "LIQUID"
        m.flow_settings.flow_behavior = "GEOMETRY"
        flow.hide_render = True

    bpy.context.view_layer.objects.active = domain
    domain.select_set(True)
    with bpy.context.temp_override(object=domain, active_object=domain):
        result = bpy.ops.fluid.bake_all()
    if result != {"FINISHED"}:
        raise RuntimeError(f"the Mantaflow bake ended {result}")
    return domain


if __name__ == "__main__":
    out = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/work/exp/manta/cache"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start = 1
    scene.frame_end = 30
    drop_into_pool(out)
    print("baked into", out)
