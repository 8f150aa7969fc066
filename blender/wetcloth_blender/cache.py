"""The result on the cloth object: a PC2 point cache in the object's own space, played by a
Mesh Cache modifier put first on the object.

The command writes the cloth in world space, Y up (the run's frames and its PC2). Loading turns
every frame back into Blender's axes and through the inverse of the cloth's world matrix at
export (kept in ``bake.json``), in double precision, and writes ``<cache_dir>/cloth.pc2`` (to
``cloth.pc2.part``, renamed when whole, so the modifier never reads half a file). The object
keeps its transform and its mesh; Free removes the modifier and keeps the files.
"""

import array
import json
import os
import struct
import sys

import bpy

from . import geometry as g

MODIFIER = "wetcloth"
CACHE_FILE = "cloth.pc2"
PC2_HEADER = struct.Struct("<12siiffi")


class CacheError(Exception):
    pass


def read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _floats_le(data):
    a = array.array("f")
    a.frombytes(data)
    if sys.byteorder != "little":
        a.byteswap()
    return a


def read_pc2(path):
    """(vertices, frames, iterator of flat float arrays (x0 y0 z0 x1 ...) per frame)."""
    f = open(path, "rb")
    head = f.read(PC2_HEADER.size)
    if len(head) != PC2_HEADER.size:
        f.close()
        raise CacheError(f"{path}: not a PC2 file (too short)")
    magic, version, n, _start, _rate, frames = PC2_HEADER.unpack(head)
    if magic != b"POINTCACHE2\0" or n <= 0 or frames < 0:
        f.close()
        raise CacheError(f"{path}: not a PC2 file")
    size = os.path.getsize(path)
    if size < PC2_HEADER.size + 12 * n * frames:
        f.close()
        raise CacheError(f"{path}: cut short ({size} bytes for {frames} frames of {n} vertices)")

    def frames_iter():
        with f:
            for _ in range(frames):
                yield _floats_le(f.read(12 * n))

    return n, frames, frames_iter()


def read_obj_frames(run_dir, frames, n):
    """The run's OBJ frames 0..frames-1 (64-bit text) as flat float lists."""

    def frames_iter():
        for k in range(frames):
            path = os.path.join(run_dir, "frames", f"frame_{k:04d}.obj")
            out = []
            with open(path, encoding="utf-8") as f:
                for line in f:
                    if line.startswith("v "):
                        parts = line.split()
                        out += (float(parts[1]), float(parts[2]), float(parts[3]))
            if len(out) != 3 * n:
                raise CacheError(f"{path}: {len(out) // 3} vertices where the cloth has {n}")
            yield out

    return frames_iter()


def run_frames(run_dir):
    """The run's state: (run.json, number of whole frames, frame iterator or None). Uses the
    run's PC2 when the run is complete (fast), else its OBJ frames (a prefix)."""
    info_path = os.path.join(run_dir, "run.json")
    if not os.path.exists(info_path):
        raise CacheError(f"No run in {run_dir}: bake first")
    info = read_json(info_path)
    frames = int(info.get("frames", 0))
    n = int(info["mesh"]["vertices"]) if "mesh" in info else 0
    if frames <= 0:
        return info, 0, None
    pc2 = os.path.join(run_dir, f"{info['name']}.pc2")
    if info.get("status") == "complete" and os.path.exists(pc2):
        pn, pframes, it = read_pc2(pc2)
        if pn == n and pframes == frames:
            return info, frames, it
    return info, frames, read_obj_frames(run_dir, frames, n)


def write_object_space_pc2(path, record, frames, it):
    """Writes the frames from ``it`` (world, Y up) as a PC2 in the cloth object's space."""
    inv = g.inverse(record["matrix_world"])
    n = int(record["vertices"])
    (a0, a1, a2, t0), (b0, b1, b2, t1), (c0, c1, c2, t2) = inv[0], inv[1], inv[2]
    tmp = path + ".part"
    with open(tmp, "wb") as f:
        f.write(PC2_HEADER.pack(b"POINTCACHE2\0", 1, n, float(record["frame_start"]), 1.0, frames))
        for flat in it:
            out = array.array("f", bytes(12 * n))
            for i in range(n):
                # wetcloth (x, y, z) is Blender (x, -z, y) in world space; then into the object.
                x, y, z = flat[3 * i], -flat[3 * i + 2], flat[3 * i + 1]
                out[3 * i] = a0 * x + a1 * y + a2 * z + t0
                out[3 * i + 1] = b0 * x + b1 * y + b2 * z + t1
                out[3 * i + 2] = c0 * x + c1 * y + c2 * z + t2
            if sys.byteorder != "little":
                out.byteswap()
            f.write(out.tobytes())
    os.replace(tmp, path)


def modifier(obj):
    for m in obj.modifiers:
        if m.type == "MESH_CACHE" and m.name.startswith(MODIFIER):
            return m
    return None


def free(obj):
    """Removes the cache modifier (the files stay). True when there was one."""
    m = modifier(obj)
    if m is None:
        return False
    obj.modifiers.remove(m)
    return True


def _move_first(obj, mod):
    if obj.modifiers[0] == mod:
        return
    if hasattr(obj.modifiers, "move"):  # Blender 3.5 and later
        obj.modifiers.move(list(obj.modifiers).index(mod), 0)
        return
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)


def load(scene, cache_dir, obj):
    """Turns the run in ``cache_dir/run`` into the object's cache and puts the modifier first on
    ``obj``. Returns (frames loaded, run.json)."""
    rec_path = os.path.join(cache_dir, "bake.json")
    if not os.path.exists(rec_path):
        raise CacheError(f"Nothing baked in {cache_dir}: bake first")
    record = read_json(rec_path)
    n = len(obj.data.vertices)
    if n != record["vertices"]:
        raise CacheError(
            f"{obj.name} has {n} vertices and the bake {record['vertices']}: the mesh changed since, bake again"
        )
    info, frames, it = run_frames(os.path.join(cache_dir, "run"))
    if frames == 0:
        raise CacheError("The run wrote no frame: nothing to load")
    if "mesh" not in info or info["mesh"].get("vertices") != n:
        raise CacheError(f"The run in {cache_dir}/run is not of this cloth ({n} vertices)")
    path = os.path.join(cache_dir, CACHE_FILE)
    write_object_space_pc2(path, record, frames, it)
    m = modifier(obj)
    if m is None:
        m = obj.modifiers.new(MODIFIER, "MESH_CACHE")
    _move_first(obj, m)
    m.cache_format = "PC2"
    raw = scene.wetcloth.cache_dir or "//wetcloth_cache/"
    m.filepath = os.path.join(raw, CACHE_FILE) if raw.startswith("//") else path
    m.forward_axis, m.up_axis = "POS_Y", "POS_Z"
    m.flip_axis = set()
    m.deform_mode = "OVERWRITE"
    m.interpolation = "LINEAR"
    m.time_mode, m.play_mode = "FRAME", "SCENE"
    m.frame_start = float(record["frame_start"])
    m.frame_scale = 1.0
    m.factor = 1.0
    obj.update_tag()
    return frames, info
