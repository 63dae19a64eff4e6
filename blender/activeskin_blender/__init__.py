"""activeskin for Blender: a surface that follows a particle simulation through time.

Bakes a skin (Desbrun & Cani's active implicit surface, through the activeskin Python
package) on a particle system of the scene, a mesh object's points, a Mantaflow liquid
domain's OpenVDB cache (its `phi` and `velocity`) or a particle file sequence (PLY, VTK,
VTU, BGEO, CSV: whatever `activeskin particles` reads), frame by frame, into a cache
folder of PLY meshes (with the surface's velocity per vertex), and where asked a USD
shot and VDB level sets, and shows the baked surface as a mesh object that follows the
timeline, with a `velocity` point attribute for motion blur. Sidebar (N) > activeskin in
the 3D viewport.
"""

bl_info = {
    "name": "activeskin",
    "author": "activeskin",
    "version": (0, 1, 0),
    "blender": (3, 0, 0),
    "location": "3D Viewport > Sidebar > activeskin",
    "description": "Skin a particle simulation with a surface that follows it without lag or flicker",
    "category": "Physics",
}

import glob
import os
import re
import sys
import zipfile

import bpy
import mathutils
import numpy as np

CACHE_NAME = "skin_{frame:04d}.ply"
VDB_NAME = "skin_{frame:04d}.vdb"
USD_NAME = "skin.usda"
MANTAFLOW_DATA = os.path.join("data", "fluid_data_####.vdb")
DISPLAY_NAME = "ActiveSkin"
# The Colliders collection as the library reads it: one OBJ for the bake (one a frame when
# they move), another for the live preview.
COLLIDER_NAME = "collider.obj"
COLLIDER_FRAMES = "collider.####.obj"
PREVIEW_COLLIDER_NAME = "preview_collider.obj"
PREVIEW_COLLIDER_FRAMES = "preview_collider.####.obj"


def _activeskin():
    """The activeskin package: installed, or unpacked once from the wheel beside the
    add-on (the 3.x add-on zip bundles it; 4.2+ extensions install it themselves)."""
    try:
        import activeskin

        return activeskin
    except ImportError:
        pass
    here = os.path.dirname(os.path.abspath(__file__))
    wheels = sorted(glob.glob(os.path.join(here, "wheels", "activeskin-*.whl")))
    if not wheels:
        raise ImportError(
            "the activeskin Python package is missing: install the add-on zip that bundles "
            "its wheel, or pip install it into Blender's Python"
        )
    vendor = os.path.join(here, "vendor")
    if not os.path.isdir(os.path.join(vendor, "activeskin")):
        with zipfile.ZipFile(wheels[-1]) as wheel:
            wheel.extractall(vendor)
    if vendor not in sys.path:
        sys.path.insert(0, vendor)
    import activeskin

    return activeskin


# The package's messages name a setting as the argument that sets it (`radius=`); the
# panel says it by its label.
_LABELS = {
    "radius=": "Particle radius",
    "voxel_size=": "Voxel size",
    "alpha=": "Attraction α",
    "beta=": "Tension β",
    "smooth=": "Smoothing",
    "fps=": "the scene's frame rate",
    "frames=": "the frame range",
    "collider_gap=": "Collider gap",
    "collider_depth=": "Into colliders",
    "collider=": "Colliders",
}


def _one_line(error):
    text = str(error).strip().splitlines()
    if not text:
        return type(error).__name__
    line = text[0]
    for argument, label in _LABELS.items():
        line = re.sub(r"(?<![\w.])" + re.escape(argument), label, line)
    return line


def _frame_path(pattern, frame):
    """A file of a frame pattern as the commands name it (`####`, `%04d` and `$F4` padded,
    `#`, `$F` and `{}` unpadded as SPlisHSPlasH numbers); Blender's `//` made absolute."""
    return os.fspath(_activeskin().frame_path(bpy.path.abspath(pattern), frame))


def _cache_dir(settings):
    return bpy.path.abspath(settings.cache_dir)


class ActiveSkinSettings(bpy.types.PropertyGroup):
    source: bpy.props.EnumProperty(
        name="Source",
        items=[
            ("PARTICLES", "Particle system", "The particles of an object's particle system"),
            ("POINTS", "Object's points",
             "The vertices of a mesh object, as Sequence Loader, Alembic or Geometry Nodes "
             "bring particles in (with their velocity and id attributes when present)"),
            ("MANTAFLOW", "Mantaflow liquid",
             "A liquid domain's cache in OpenVDB: its phi level set, carried by its velocity"),
            ("FILES", "Files", "A particle file sequence: PLY, VTK, VTU, BGEO, CSV"),
        ],
        default="PARTICLES",
    )
    emitter: bpy.props.PointerProperty(name="Object", type=bpy.types.Object)
    region: bpy.props.PointerProperty(
        name="Region",
        type=bpy.types.Object,
        description="Cut the surface to this object's bounding box (a box, the liquid's "
        "domain): open on its sides, as open water meets the frame; the skin is the whole",
    )
    colliders: bpy.props.PointerProperty(
        name="Colliders",
        type=bpy.types.Collection,
        description="Objects the liquid meets (a tank, obstacles; closed meshes): where the "
        "surface comes near them it is carried on to their faces instead of closing into a "
        "shell off them; the skin is the same",
    )
    colliders_move: bpy.props.BoolProperty(
        name="Moving colliders", default=False,
        description="Read the colliders again on every frame (an animated obstacle); off, "
        "as they stand when the bake or the preview starts",
    )
    collider_gap: bpy.props.FloatProperty(
        name="Collider gap", default=0.0, min=0.0, subtype="DISTANCE", precision=4,
        description="How near the surface must come to a collider to meet it; 0 for the "
        "default, 3 particle radii (4 voxels on a Mantaflow cache)",
    )
    collider_depth: bpy.props.FloatProperty(
        name="Into colliders", default=0.0, min=0.0, subtype="DISTANCE", precision=4,
        description="How far the surface runs into the colliders: 0 shares their faces "
        "(liquid against glass), more overlaps them",
    )
    particle_system: bpy.props.StringProperty(
        name="Particle system", description="Its name; empty for the object's active one"
    )
    pattern: bpy.props.StringProperty(
        name="Files",
        subtype="FILE_PATH",
        description="Frame pattern: #### for padded numbers, # for unpadded (SPlisHSPlasH)",
    )
    radius: bpy.props.FloatProperty(
        name="Particle radius", default=0.05, min=0.0, precision=4,
        description="Half the rest spacing of the simulation's particles",
    )
    voxel_size: bpy.props.FloatProperty(
        name="Voxel size", default=0.0, min=0.0, precision=4,
        description="0 for the default: half the particle radius, or the Mantaflow cache's",
    )
    alpha: bpy.props.FloatProperty(
        name="Attraction α", min=0.0,
        description="How fast the skin closes on the particles (1/s): lower is smoother",
    )
    use_tension: bpy.props.BoolProperty(
        name="Surface tension", default=True,
        description="Smooth the surface (particles, noisy caches); off for a clean "
        "level-set cache, which then is followed without tension's inward offset",
    )
    beta: bpy.props.FloatProperty(
        name="Tension β", default=0.0, min=0.0, precision=6,
        description="Surface tension (units²/s); 0 for the default, α·voxel²/8",
    )
    smooth: bpy.props.FloatProperty(
        name="Smoothing", min=0.0, soft_max=4.0,
        description="Smoothing of the particles' bumps, adding up from frame to frame "
        "(particles only): 0 none, 2 twice as much; droplets and thin sheets are spared",
    )
    use_velocity: bpy.props.BoolProperty(
        name="Follow the motion", default=True,
        description="Carry the skin by the particles' own motion (their ids and velocities)",
    )
    frame_start: bpy.props.IntProperty(name="Start", default=1)
    frame_end: bpy.props.IntProperty(name="End", default=100)
    cache_dir: bpy.props.StringProperty(
        name="Cache", subtype="DIR_PATH", default="//activeskin/",
        description="Folder of the baked meshes (PLY, one a frame)",
    )
    write_usd: bpy.props.BoolProperty(
        name="USD shot", default=False,
        description="Also write the surface as a USD shot (skin.usda in the cache, a layer a frame)",
    )
    write_vdb: bpy.props.BoolProperty(
        name="VDB level sets", default=False,
        description="Also write the skin as a VDB level set a frame (needs activeskin built with OpenVDB)",
    )
    use_preview: bpy.props.BoolProperty(
        name="Live preview", default=False,
        description="Rebuild the surface in the viewport as the frame changes, at a coarser "
        "voxel, without baking (the skin carried on when stepping forward, started again "
        "otherwise); renders and the bake keep the full settings",
    )
    preview_coarsening: bpy.props.FloatProperty(
        name="Preview voxel ×", default=2.0, min=1.0, soft_max=4.0,
        description="The preview's voxel over the bake's",
    )


def _tension(settings):
    """β for the library: None for its default, 0 with tension off."""
    if not settings.use_tension:
        return 0.0
    return settings.beta or None


def _particles_of(settings, scene, depsgraph):
    """This frame's particles of the scene's particle system: positions, velocities, ids
    (the particles' indices, stable in Blender)."""
    emitter = settings.emitter
    if emitter is None:
        raise ValueError("choose the object whose particle system to skin")
    evaluated = emitter.evaluated_get(depsgraph)
    systems = evaluated.particle_systems
    if len(systems) == 0:
        raise ValueError(f"{emitter.name} has no particle system")
    name = settings.particle_system
    system = systems.get(name) if name else systems.active
    if system is None:
        raise ValueError(f"{emitter.name} has no particle system named {name}")
    particles = system.particles
    n = len(particles)
    location = np.empty(3 * n, np.float32)
    velocity = np.empty(3 * n, np.float32)
    alive = np.empty(n, np.int32)
    particles.foreach_get("location", location)
    particles.foreach_get("velocity", velocity)
    particles.foreach_get("alive_state", alive)
    # foreach_get gives the enum's values, not its order.
    keep = alive == bpy.types.Particle.bl_rna.properties["alive_state"].enum_items["ALIVE"].value
    ids = np.arange(n, dtype=np.int64)[keep]
    # Blender's particle velocities are in units per second.
    return location.reshape(n, 3)[keep], velocity.reshape(n, 3)[keep], ids


def _mantaflow_domain(settings):
    """The liquid domain's settings and the pattern of its OpenVDB data cache."""
    domain = settings.emitter
    if domain is None:
        raise ValueError("choose the Mantaflow liquid domain to skin")
    fluid = next((m for m in domain.modifiers if m.type == "FLUID" and m.fluid_type == "DOMAIN"), None)
    if fluid is None:
        raise ValueError(f"{domain.name} is not a fluid domain")
    d = fluid.domain_settings
    if d.domain_type != "LIQUID":
        raise ValueError(f"{domain.name} is a {d.domain_type.lower()} domain, not a liquid")
    if d.cache_data_format != "OPENVDB":
        raise ValueError(
            f"{domain.name} caches its data as {d.cache_data_format}: set Cache > Format "
            "Volumes to OpenVDB and bake again"
        )
    pattern = os.path.join(bpy.path.abspath(d.cache_directory), MANTAFLOW_DATA)
    return d, pattern


def _mantaflow_placement(domain, settings):
    """Where the cache's voxel (0, 0, 0) is in the scene: Mantaflow writes its grids from
    the domain's lowest corner, its values at the cells' centres."""
    corners = [domain.matrix_world @ mathutils.Vector(c) for c in domain.bound_box]
    lowest = mathutils.Vector([min(c[i] for c in corners) for i in range(3)])
    dx = max(domain.dimensions) / settings.resolution_max
    return lowest + mathutils.Vector((0.5 * dx,) * 3)


def _skin_shift(settings):
    """What the skin's coordinates are less than the scene's: a Mantaflow cache starts at
    its placement; particles are where they are (None)."""
    if settings.source == "MANTAFLOW" and settings.emitter is not None:
        fluid, _ = _mantaflow_domain(settings)
        return _mantaflow_placement(settings.emitter, fluid)
    return None


def _region_of(settings):
    """The region object's world bounding box in the skin's coordinates, or None."""
    box = settings.region
    if box is None:
        return None
    corners = [box.matrix_world @ mathutils.Vector(c) for c in box.bound_box]
    lo = [min(c[i] for c in corners) for i in range(3)]
    hi = [max(c[i] for c in corners) for i in range(3)]
    at = _skin_shift(settings)
    if at is not None:
        lo, hi = ([v[i] - at[i] for i in range(3)] for v in (lo, hi))
    return tuple(lo), tuple(hi)


def _write_colliders(settings, depsgraph, path):
    """The Colliders collection's objects (their evaluated meshes, modifiers applied) as
    one OBJ at `path`, in the skin's coordinates; written to a temporary name, then
    renamed."""
    triangles, vertices, count = [], [], 0
    for obj in settings.colliders.all_objects:
        if obj.type not in {"MESH", "CURVE", "SURFACE", "META", "FONT"}:
            continue
        evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            mesh.calc_loop_triangles()
            n, t = len(mesh.vertices), len(mesh.loop_triangles)
            co = np.empty(3 * n, np.float64)
            mesh.vertices.foreach_get("co", co)
            tri = np.empty(3 * t, np.int64)
            mesh.loop_triangles.foreach_get("vertices", tri)
        finally:
            evaluated.to_mesh_clear()
        matrix = np.array(evaluated.matrix_world, np.float64)
        vertices.append(co.reshape(n, 3) @ matrix[:3, :3].T + matrix[:3, 3])
        triangles.append(tri.reshape(t, 3) + count)
        count += n
    if not count or not sum(len(t) for t in triangles):
        raise ValueError(f"Colliders: {settings.colliders.name} holds no mesh")
    vertices = np.concatenate(vertices)
    at = _skin_shift(settings)
    if at is not None:
        vertices -= np.array(at, np.float64)
    partial = path + ".partial"
    with open(partial, "w") as out:
        np.savetxt(out, vertices, fmt="v %.9g %.9g %.9g")
        np.savetxt(out, np.concatenate(triangles) + 1, fmt="f %d %d %d")
    os.replace(partial, path)


def _collider_options(settings, folder, preview=False):
    """The skin's collider= arguments for the Colliders collection: its OBJ in `folder`
    (a frame pattern when they move, each frame written by _collider_frame); none without."""
    if settings.colliders is None:
        return {}
    moving, still = (PREVIEW_COLLIDER_FRAMES, PREVIEW_COLLIDER_NAME) if preview else (COLLIDER_FRAMES, COLLIDER_NAME)
    return {
        "collider": os.path.join(folder, moving if settings.colliders_move else still),
        "collider_gap": settings.collider_gap or None,
        "collider_depth": settings.collider_depth,
    }


def _collider_frame(settings, depsgraph, options, frame):
    """Writes the colliders' file the skin reads for `frame`: each frame's when they move."""
    if options and settings.colliders_move:
        _write_colliders(settings, depsgraph, _frame_path(options["collider"], frame))


def _frame_particles(settings, scene, depsgraph, frame):
    """The particles of `frame` (the scene at it for a particle system or an object's
    points): positions, velocities and ids (None without Follow the motion)."""
    if settings.source == "PARTICLES":
        positions, velocities, ids = _particles_of(settings, scene, depsgraph)
    elif settings.source == "POINTS":
        positions, velocities, ids = _points_of(settings, depsgraph)
    else:
        read = _activeskin().read_particles(_frame_path(settings.pattern, frame))
        positions, velocities, ids = read["positions"], read["velocities"], read["ids"]
    if not settings.use_velocity:
        velocities, ids = None, None
    return positions, velocities, ids


def _points_of(settings, depsgraph):
    """This frame's vertices of a mesh object as particles, in world space: positions, its
    `velocity` point attribute (units per second, what Blender's motion blur reads) and
    its `id` point attribute, each None when absent."""
    source = settings.emitter
    if source is None:
        raise ValueError("choose the object whose points are the particles")
    if source.type != "MESH":
        raise ValueError(f"{source.name} is a {source.type.lower()}, not a mesh: its points cannot be read")
    evaluated = source.evaluated_get(depsgraph)
    mesh = evaluated.data
    n = len(mesh.vertices)
    co = np.empty(3 * n, np.float32)
    mesh.vertices.foreach_get("co", co)
    matrix = np.array(evaluated.matrix_world, np.float64)
    linear, shift = matrix[:3, :3], matrix[:3, 3]
    identity = np.array_equal(matrix, np.eye(4))
    positions = co.reshape(n, 3)
    if not identity:
        positions = (positions.astype(np.float64) @ linear.T + shift).astype(np.float32)

    def point_attribute(name, kind, field, width):
        a = mesh.attributes.get(name)
        if a is None or a.domain != "POINT" or a.data_type != kind:
            return None
        values = np.empty(width * n, np.float32 if kind != "INT" else np.int32)
        a.data.foreach_get(field, values)
        return values.reshape(n, width) if width > 1 else values

    velocities = point_attribute("velocity", "FLOAT_VECTOR", "vector", 3)
    if velocities is not None and not identity:
        velocities = (velocities.astype(np.float64) @ linear.T).astype(np.float32)
    ids = point_attribute("id", "INT", "value", 1)
    return positions, velocities, None if ids is None else ids.astype(np.int64)


class Bake:
    """One bake: the skin, the frames left, what to write. A bake stopped part-way
    resumes after the last whole frame of its cache, warming the skin up on the frames
    before as a farm chunk does (ln(40)·fps/α frames)."""

    def __init__(self, context):
        self.scene = context.scene
        self.settings = self.scene.activeskin
        s = self.settings
        if s.frame_end < s.frame_start:
            raise ValueError(f"the frame range {s.frame_start}-{s.frame_end} is empty")
        if s.source == "FILES" and not s.pattern:
            raise ValueError("choose the particle files: a pattern with #### or #")
        activeskin = _activeskin()
        if s.write_vdb and not activeskin.HAS_VDB:
            raise ValueError(
                "VDB output needs activeskin built with OpenVDB (make wheel-vdb), "
                "this one was built without"
            )
        if s.source == "MANTAFLOW":
            if not activeskin.HAS_VDB:
                raise ValueError(
                    "a Mantaflow cache is read with activeskin built with OpenVDB "
                    "(make wheel-vdb), this one was built without"
                )
            self.domain, self.pattern = _mantaflow_domain(s)
        self.cache = _cache_dir(s)
        os.makedirs(self.cache, exist_ok=True)
        self.colliders = _collider_options(s, self.cache)
        if self.colliders and not s.colliders_move:
            _write_colliders(s, context.evaluated_depsgraph_get(), self.colliders["collider"])
        done = s.frame_start - 1
        while done < s.frame_end and os.path.isfile(self._cached(done + 1)):
            done += 1
        self.done = done
        fps = self.scene.render.fps / self.scene.render.fps_base
        # As a farm chunk warms up (the commands' --warmup auto); without attraction the
        # skin never forgets its start, so from the first frame.
        warmup = _activeskin().warmup_frames(s.alpha, fps) if s.alpha > 0 else done
        self.first = s.frame_start if done < s.frame_start else max(s.frame_start, done + 1 - warmup)
        self.frames = list(range(self.first, s.frame_end + 1)) if done < s.frame_end else []
        self.fps = fps
        if s.source == "MANTAFLOW":
            # The velocity's scale and timing measured over the whole range, as the
            # `skin` command does, so that a resumed bake makes the same frames.
            self.skin, self.velocity = activeskin.skin_for_sequence(
                self.pattern,
                frames=(s.frame_start, s.frame_end),
                first_frame=self.first,
                grid="phi",
                velocity="velocity" if s.use_velocity else False,
                voxel_size=s.voxel_size or None,
                alpha=s.alpha,
                beta=_tension(s),
                fps=fps,
                velocity_grid=s.write_vdb,
                region=_region_of(s),
                **self.colliders,
            )
        else:
            self.skin = activeskin.ParticleSkin(
                s.radius,
                voxel_size=s.voxel_size or None,
                alpha=s.alpha,
                beta=_tension(s),
                smooth=s.smooth,
                fps=fps,
                first_frame=self.first,
                velocity_grid=s.write_vdb,
                region=_region_of(s),
                **self.colliders,
            )
        self.total = len(self.frames)

    def _cached(self, frame):
        return os.path.join(self.cache, CACHE_NAME.format(frame=frame))

    def step(self, context):
        """Bakes the next frame; False when none is left."""
        if not self.frames:
            return False
        frame = self.frames.pop(0)
        s = self.settings
        moving = self.colliders and s.colliders_move
        if s.source in ("PARTICLES", "POINTS") or moving:
            global _baking
            _baking = True
            try:
                self.scene.frame_set(frame)
            finally:
                _baking = False
        _collider_frame(s, context.evaluated_depsgraph_get(), self.colliders, frame)
        if s.source == "MANTAFLOW":
            path = _frame_path(self.pattern, frame)
            if not os.path.isfile(path):
                raise ValueError(f"{path}: not baked (bake the domain's data over {s.frame_start}-{s.frame_end})")
            mesh = self.skin.advance(path, self.velocity, grid="phi")
            self._write(frame, mesh)
            return True
        positions, velocities, ids = _frame_particles(s, self.scene, context.evaluated_depsgraph_get(), frame)
        mesh = self.skin.advance(positions, velocities=velocities, ids=ids)
        self._write(frame, mesh)
        return True

    def _write(self, frame, mesh):
        """The frame's outputs, unless an earlier bake wrote them (a warm-up frame)."""
        if frame <= self.done:
            return
        s = self.settings
        if s.write_usd:
            mesh.save_usd(
                os.path.join(self.cache, USD_NAME),
                (s.frame_start, s.frame_end),
                fps=self.fps,
                up="z",
                meters_per_unit=self.scene.unit_settings.scale_length,
            )
        if s.write_vdb:
            self.skin.save_vdb(os.path.join(self.cache, VDB_NAME.format(frame=frame)))
        # The PLY last: a frame is baked when its PLY is there.
        mesh.save(self._cached(frame))


class ACTIVESKIN_OT_bake(bpy.types.Operator):
    """Bake the skin over the frame range into the cache folder (Esc cancels; a bake
    started again resumes after its last frame)"""

    bl_idname = "activeskin.bake"
    bl_label = "Bake Skin"

    _timer = None
    _bake = None

    def _start(self, context):
        try:
            return Bake(context)
        except (ValueError, RuntimeError, OSError, ImportError) as e:
            self.report({"ERROR"}, _one_line(e))
            return None

    def _step(self, context):
        try:
            return self._bake.step(context)
        except (ValueError, RuntimeError, OSError, ImportError) as e:
            self.report({"ERROR"}, _one_line(e))
            raise

    def execute(self, context):
        self._bake = self._start(context)
        if self._bake is None:
            return {"CANCELLED"}
        try:
            while self._step(context):
                pass
        except (ValueError, RuntimeError, OSError, ImportError):
            return {"CANCELLED"}
        _show(context.scene)
        return {"FINISHED"}

    def invoke(self, context, event):
        self._bake = self._start(context)
        if self._bake is None:
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, max(self._bake.total, 1))
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        wm = context.window_manager
        if event.type == "ESC":
            self._finish(context)
            self.report({"WARNING"}, "bake cancelled; baking again resumes after the last frame written")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            more = self._step(context)
        except (ValueError, RuntimeError, OSError, ImportError):
            self._finish(context)
            return {"CANCELLED"}
        left = len(self._bake.frames)
        wm.progress_update(self._bake.total - left)
        context.area and context.area.header_text_set(f"activeskin: {left} frames left (Esc cancels)")
        if not more:
            self._finish(context)
            _show(context.scene)
            return {"FINISHED"}
        return {"RUNNING_MODAL"}

    def _finish(self, context):
        wm = context.window_manager
        if self._timer:
            wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.area:
            context.area.header_text_set(None)


def read_ply(path):
    """A mesh PLY as activeskin writes it: positions, triangles, velocities (or None)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    vertices = faces = 0
    properties = []
    for line in header:
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            vertices = int(words[2])
        elif words[:2] == ["element", "face"]:
            faces = int(words[2])
        elif words[:2] == ["property", "float"]:
            properties.append(words[2])
    k = len(properties)
    table = np.frombuffer(data, np.float32, vertices * k, end).reshape(vertices, k)
    records = np.frombuffer(
        data, np.dtype([("n", "u1"), ("i", "<i4", (3,))]), faces, end + 4 * k * vertices
    )
    velocity = None
    if "vx" in properties:
        at = properties.index("vx")
        velocity = table[:, at : at + 3]
    return table[:, 0:3], records["i"], velocity


def _display_object(scene):
    obj = bpy.data.objects.get(DISPLAY_NAME)
    if obj is None:
        mesh = bpy.data.meshes.new(DISPLAY_NAME)
        obj = bpy.data.objects.new(DISPLAY_NAME, mesh)
        scene.collection.objects.link(obj)
    return obj


def load_frame(scene, frame):
    """The display object's mesh set to the cached surface of `frame` (empty when the
    frame is not baked)."""
    path = os.path.join(_cache_dir(scene.activeskin), CACHE_NAME.format(frame=frame))
    obj = _display_object(scene)
    mesh = obj.data
    mesh.clear_geometry()
    if not os.path.isfile(path):
        return obj
    return _set_mesh(obj, *read_ply(path))


def _set_mesh(obj, positions, triangles, velocity):
    """The object's mesh set to these triangles, with the `velocity` point attribute."""
    mesh = obj.data
    mesh.clear_geometry()
    n, m = len(positions), len(triangles)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", positions.ravel())
    mesh.loops.add(3 * m)
    mesh.loops.foreach_set("vertex_index", np.asarray(triangles, np.int32).ravel())
    mesh.polygons.add(m)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * m, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(m, 3, np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(m, bool))
    if velocity is not None:
        # What Cycles' motion blur reads on a mesh whose vertices change every frame.
        attribute = mesh.attributes.new("velocity", "FLOAT_VECTOR", "POINT")
        attribute.data.foreach_set("vector", np.ascontiguousarray(velocity).ravel())
    mesh.update()
    return obj


def _show(scene):
    obj = load_frame(scene, scene.frame_current)
    s = scene.activeskin
    if s.source == "MANTAFLOW" and s.emitter is not None:
        fluid, _ = _mantaflow_domain(s)
        obj.matrix_world = mathutils.Matrix.Translation(_mantaflow_placement(s.emitter, fluid))


# A bake sets the frame itself: the frame handler leaves it alone then.
_baking = False
# The live preview's skin, what it was made with, and the last frame it took.
_preview = {"skin": None, "key": None, "frame": None}


def _rendering():
    running = getattr(bpy.app, "is_job_running", None)
    return bool(running and running("RENDER"))


def preview_frame(scene, depsgraph):
    """The live preview: the display object's mesh set to the surface of the current
    frame, at the preview's coarser voxel; the skin carried on from the frame before
    when the frame stepped forward with the same settings, started again otherwise.
    Returns whether it carried on."""
    s = scene.activeskin
    if s.source == "MANTAFLOW":
        raise ValueError("the live preview skins particles: bake a Mantaflow domain")
    activeskin = _activeskin()
    frame = scene.frame_current
    voxel = (s.voxel_size or activeskin.particle_voxel_size(s.radius)) * s.preview_coarsening
    fps = scene.render.fps / scene.render.fps_base
    folder = _cache_dir(s)
    colliders = _collider_options(s, folder, preview=True)
    key = (s.source, s.emitter and s.emitter.name, s.particle_system, s.pattern, s.radius,
           voxel, s.alpha, _tension(s), s.smooth, s.use_velocity, _region_of(s), fps,
           s.colliders and s.colliders.name, s.colliders_move, s.collider_gap, s.collider_depth)
    same = _preview["skin"] is not None and _preview["key"] == key
    if same and _preview["frame"] == frame:
        return True
    carried = same and _preview["frame"] == frame - 1
    if colliders:
        os.makedirs(folder, exist_ok=True)
        if not carried and not s.colliders_move:
            _write_colliders(s, depsgraph, colliders["collider"])
        _collider_frame(s, depsgraph, colliders, frame)
    if not carried:
        _preview.update(skin=None, frame=None, key=key)
        _preview["skin"] = activeskin.ParticleSkin(
            s.radius, voxel_size=voxel, alpha=s.alpha, beta=_tension(s), smooth=s.smooth,
            fps=fps, first_frame=frame, region=_region_of(s), **colliders,
        )
    positions, velocities, ids = _frame_particles(s, scene, depsgraph, frame)
    mesh = _preview["skin"].advance(positions, velocities=velocities, ids=ids)
    _preview["frame"] = frame
    obj = _display_object(scene)
    obj.matrix_world = mathutils.Matrix.Identity(4)
    _set_mesh(obj, mesh.vertices, mesh.triangles, mesh.velocities)
    return carried


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph=None, *args):
    if _baking:
        return
    try:
        if scene.activeskin.use_preview and not _rendering():
            preview_frame(scene, depsgraph or bpy.context.evaluated_depsgraph_get())
        elif bpy.data.objects.get(DISPLAY_NAME) is not None:
            load_frame(scene, scene.frame_current)
    except (OSError, ValueError, RuntimeError) as e:
        _preview.update(skin=None, frame=None, key=None)
        print(f"activeskin: {_one_line(e)}")


class ACTIVESKIN_PT_panel(bpy.types.Panel):
    bl_label = "activeskin"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "activeskin"

    def draw(self, context):
        s = context.scene.activeskin
        layout = self.layout
        layout.prop(s, "source")
        if s.source == "PARTICLES":
            layout.prop(s, "emitter")
            layout.prop(s, "particle_system")
        elif s.source in ("POINTS", "MANTAFLOW"):
            layout.prop(s, "emitter", text="Domain" if s.source == "MANTAFLOW" else "Object")
        else:
            layout.prop(s, "pattern")
        if s.source != "MANTAFLOW":
            layout.prop(s, "radius")
            layout.prop(s, "smooth")
        layout.prop(s, "voxel_size")
        layout.prop(s, "alpha")
        layout.prop(s, "use_tension")
        if s.use_tension:
            layout.prop(s, "beta")
        layout.prop(s, "use_velocity")
        layout.prop(s, "region")
        layout.prop(s, "colliders")
        if s.colliders is not None:
            row = layout.row(align=True)
            row.prop(s, "collider_gap")
            row.prop(s, "collider_depth")
            layout.prop(s, "colliders_move")
        row = layout.row(align=True)
        row.prop(s, "frame_start")
        row.prop(s, "frame_end")
        layout.prop(s, "cache_dir")
        row = layout.row(align=True)
        row.prop(s, "write_usd")
        row.prop(s, "write_vdb")
        layout.operator(ACTIVESKIN_OT_bake.bl_idname, icon="MOD_FLUIDSIM")
        if s.source != "MANTAFLOW":
            row = layout.row(align=True)
            row.prop(s, "use_preview")
            row.prop(s, "preview_coarsening")


classes = (ActiveSkinSettings, ACTIVESKIN_OT_bake, ACTIVESKIN_PT_panel)


def _library_defaults():
    """α and the smoothing default to the library's own values, read as the add-on
    registers (the package it bundles or Blender installed for it)."""
    library = _activeskin()
    settings = ActiveSkinSettings.__annotations__
    for name, default in (
        ("alpha", library.DEFAULT_ALPHA),
        ("smooth", library.DEFAULT_PARTICLE_SMOOTHING),
    ):
        prop = settings[name]
        settings[name] = prop.function(**{**prop.keywords, "default": default})


def register():
    _library_defaults()
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.activeskin = bpy.props.PointerProperty(type=ActiveSkinSettings)
    bpy.app.handlers.frame_change_post.append(_on_frame_change)


def unregister():
    if _on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(_on_frame_change)
    # The preview's skin (and the thread its frames run on) goes with the add-on.
    _preview.update(skin=None, key=None, frame=None)
    del bpy.types.Scene.activeskin
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
