"""Imports the first and last frame of a run into Blender and prints what Blender sees.

    blender -b --python tools/blender_check.py -- out/thesis-demo

Checks the OBJ frames as a real client reads them: vertex and face counts, the UV layer, and
the cloth's height after Blender converts our Y-up metres to its Z-up (it should match
max_height in metrics.csv). Tested with Blender 3.4 (Debian's `blender`).
"""
import glob
import sys

import bpy

run = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "out/thesis-demo"
bpy.ops.wm.read_factory_settings(use_empty=True)
files = sorted(glob.glob(f"{run}/frames/frame_*.obj"))
if not files:
    sys.exit(f"no frames in {run}/frames")
print(f"{len(files)} frames in {run}")
for path in [files[0], files[-1]]:
    before = set(bpy.data.objects)
    bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
    obj = next(o for o in bpy.data.objects if o not in before)
    heights = [(obj.matrix_world @ v.co).z for v in obj.data.vertices]
    print(
        f"{path.split('/')[-1]}: {len(obj.data.vertices)} vertices, "
        f"{len(obj.data.polygons)} faces, {len(obj.data.uv_layers)} UV layer(s), "
        f"highest point {max(heights):.4f} m"
    )
