"""Applies a run's PC2 and MDD caches in Blender and compares what Blender shows with the frames.

    blender -b --python tools/blender_cache_check.py -- RUN_DIR [--frames 0,5,10] [--render PNG]
        [--obj MESH.obj]

Imports RUN_DIR/rest.obj (or, with --obj, another OBJ of the same vertices: a mesh cloth's
original file, which the caches apply to unchanged) with Blender's OBJ importer (forward -Z, up Y), adds a Mesh Cache
modifier with RUN_DIR/<scene name>.pc2, then one with the .mdd, and at each checked frame
compares every evaluated vertex with that frame's OBJ file (frames/frame_NNNN.obj). The settings
under which they match (written in docs/export.md):

- OBJ import: forward axis -Z, up axis Y. The importer keeps the file's Y-up coordinates in the
  mesh and turns the object 90 degrees about X, so the object stands Z-up in Blender.
- Mesh Cache modifier: forward axis +Y, up axis +Z (its defaults: no conversion, because the
  cache holds the same Y-up coordinates as the mesh and the object's rotation does the rest),
  time mode Frame, frame start 0, frame scale 1: scene frame k shows wetcloth frame k. For MDD,
  time mode Time reads the same frames by their times in seconds (scene frame rate = the run's
  frame rate). Not for PC2: Blender 3.4 computes a PC2 frame in Time mode as
  (seconds / fps - start) / sampling, which no header in frames (3ds Max's convention, and
  Blender's own PC2 exporter's) can satisfy; use Frame mode.

Checks, for each format: the evaluated local coordinates equal the OBJ's within float32 round-off
(relative 2^-23), in Frame mode at every checked frame and, for MDD, in Time mode at the last; the world
coordinates are (x, -z, y) of the file's, so the highest world z equals the OBJ's highest y.
With --render, renders the last frame (PC2 applied) with Cycles on the CPU into PNG. Exits 1 on
failure. Tested with Blender 3.4 (Debian's `blender`).
"""
import json
import os
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
if not argv:
    sys.exit(__doc__)
run_dir = argv[0]
render_png = argv[argv.index("--render") + 1] if "--render" in argv else None
mesh_obj = argv[argv.index("--obj") + 1] if "--obj" in argv else os.path.join(run_dir, "rest.obj")
with open(os.path.join(run_dir, "run.json")) as f:
    run = json.load(f)
frames = run["frames"]
checked = (
    [int(k) for k in argv[argv.index("--frames") + 1].split(",")]
    if "--frames" in argv
    else sorted({0, 1, frames // 2, frames - 1})
)
failures = []


def obj_vertices(k):
    with open(os.path.join(run_dir, "frames", f"frame_{k:04d}.obj")) as f:
        return [tuple(map(float, line.split()[1:4])) for line in f if line.startswith("v ")]


def max_error(got, want):
    """Largest difference in units of float32 round-off (relative 2^-23, floor 1)."""
    worst = 0.0
    for g, w in zip(got, want):
        for a, b in zip(g, w):
            worst = max(worst, abs(a - b) / (max(1.0, abs(b)) * 2.0**-23))
    return worst


bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = max(1, round(run["frame_rate"]))
scene.render.fps_base = scene.render.fps / run["frame_rate"]
scene.frame_start, scene.frame_end = 0, frames - 1
bpy.ops.wm.obj_import(filepath=mesh_obj, forward_axis="NEGATIVE_Z", up_axis="Y")
obj = bpy.context.selected_objects[0]
n = run["mesh"]["vertices"] if "mesh" in run else run["resolution"][0] * run["resolution"][1]
if len(obj.data.vertices) != n:
    sys.exit(f"{mesh_obj} imported with {len(obj.data.vertices)} vertices, run.json says {n}")
print(f"{os.path.basename(mesh_obj)}: {n} vertices, {len(obj.data.polygons)} faces")


def evaluated():
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    mesh = ev.to_mesh()
    local = [tuple(v.co) for v in mesh.vertices]
    world = [tuple(ev.matrix_world @ v.co) for v in mesh.vertices]
    ev.to_mesh_clear()
    return local, world


for fmt in ("pc2", "mdd"):
    path = os.path.join(run_dir, f"{run['name']}.{fmt}")
    if not os.path.exists(path):
        failures.append(f"{path}: missing")
        continue
    mod = obj.modifiers.new(f"wetcloth {fmt}", "MESH_CACHE")
    mod.cache_format = fmt.upper()
    mod.filepath = path
    mod.forward_axis, mod.up_axis = "POS_Y", "POS_Z"
    mod.time_mode, mod.play_mode = "FRAME", "SCENE"
    mod.frame_start, mod.frame_scale = 0.0, 1.0
    mod.interpolation = "LINEAR"
    modes = (("FRAME", checked),) + ((("TIME", [frames - 1]),) if fmt == "mdd" else ())
    for mode, ks in modes:
        mod.time_mode = mode
        for k in ks:
            scene.frame_set(k)
            local, world = evaluated()
            want = obj_vertices(k)
            err = max_error(local, want)
            top_world = max(p[2] for p in world)
            top_file = max(p[1] for p in want)
            ok = len(local) == len(want) and err <= 1.0 and abs(top_world - top_file) < 1e-6
            print(
                f"{fmt} ({mode.lower()} mode) frame {k}: {len(local)} vertices, largest difference "
                f"{err:.2f} float32 ulps, highest point {top_world:.5f} m (file {top_file:.5f} m)"
                + ("" if ok else "  <-- MISMATCH")
            )
            if not ok:
                failures.append(f"{fmt} {mode} frame {k}")
    if fmt == "mdd" or render_png is None:
        obj.modifiers.remove(mod)

if render_png:
    scene.frame_set(frames - 1)
    bpy.ops.object.shade_smooth()
    cloth_mat = bpy.data.materials.new("satin")
    cloth_mat.use_nodes = True
    bsdf = cloth_mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.42, 0.04, 0.08, 1)
    bsdf.inputs["Roughness"].default_value = 0.35
    obj.data.materials.append(cloth_mat)
    if "mesh" in run:
        lo, hi = run["mesh"]["bounds"]
        size = max(hi[0] - lo[0], hi[2] - lo[2])
    else:
        size = max(run["size"])
    bpy.ops.mesh.primitive_plane_add(size=4 * size, location=(0, 0, 0))
    table = bpy.data.materials.new("table")
    table.use_nodes = True
    table.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.6, 0.6, 0.58, 1)
    bpy.context.object.data.materials.append(table)
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 2), rotation=(0.6, 0.2, 0.8))
    bpy.context.object.data.energy = 3
    bpy.ops.object.camera_add(location=(0.95 * size, -1.35 * size, 0.75 * size))
    cam = bpy.context.object
    target = bpy.data.objects.new("target", None)
    scene.collection.objects.link(target)
    target.location = (0, 0, 0.1 * size)
    track = cam.constraints.new("TRACK_TO")
    track.target = target
    scene.camera = cam
    world = bpy.data.worlds.new("sky")
    world.color = (0.4, 0.45, 0.5)
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 480, 300
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 100
    scene.render.filepath = os.path.abspath(render_png)
    bpy.ops.render.render(write_still=True)
    print(f"rendered frame {frames - 1} to {render_png}")

if failures:
    print("FAILED:", ", ".join(failures))
    sys.exit(1)
print(f"Blender cache check passed: pc2 and mdd match the OBJ frames at frames {checked}")
