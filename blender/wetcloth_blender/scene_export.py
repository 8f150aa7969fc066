"""Writes a Blender scene as a wetcloth scene: ``scene.toml`` and the OBJ files it names.

Conventions (docs/blender.md):

- Blender frame ``frame_start + k`` is wetcloth frame ``k``; the duration is
  ``(frame_end - frame_start) / fps`` with ``fps = render.fps / render.fps_base``, the scene's
  output frame rate.
- Everything is written in world space, Y up (``geometry.to_sim``). The cloth is its mesh's
  vertices through the object's world matrix at the first frame, in the mesh's vertex order
  (particle k is vertex k), faces as Blender winds them; the matrix is kept (``bake.json``) so
  that the result can be turned back into the object's own space.
- Colliders are sampled at every frame of the range: a transform that moves becomes ``keys``
  (one per frame: the offset of the shape's reference point and its rotation). A mesh is its
  evaluated mesh at the first frame, taken as rigid.
- A pin group becomes one ``[[grab]]`` per vertex with a single key (held still); a hand, one
  ``[[grab]]`` per vertex of its group with a key per frame following the target's transform.
"""

import json
import math
import os
import re

import bpy

from . import geometry as g
from .props import PARAMETERS


class ExportError(Exception):
    """A scene that cannot be written; ``key`` is the add-on property or scene key it is about,
    ``obj`` the object's name."""

    def __init__(self, message, key="", obj=""):
        super().__init__(message)
        self.key = key
        self.obj = obj


def fmt(x):
    """A float as TOML: Python's shortest exact text (``0.1``, ``1e-05``, ``-0.0``)."""
    x = float(x)
    if not math.isfinite(x):
        raise ExportError(f"a value is not finite: {x}")
    return repr(x)


def fmt32(x):
    """A value Blender keeps as a 32-bit float, written as the shortest text that reads back as
    that float (0.02 rather than 0.019999999552965164)."""
    import struct

    x = float(x)
    if not math.isfinite(x):
        raise ExportError(f"a value is not finite: {x}")
    target = struct.unpack("<f", struct.pack("<f", x))[0]
    for digits in range(1, 10):
        s = f"{x:.{digits}g}"
        if struct.unpack("<f", struct.pack("<f", float(s)))[0] == target:
            return repr(float(s))
    return repr(x)


def vec(v):
    return "[" + ", ".join(fmt(c) for c in v) + "]"


def toml_string(s):
    out = json.dumps(str(s), ensure_ascii=False)
    return out.replace("\x7f", "\\u007f")


def comment(s):
    """Text safe inside a TOML comment (no control characters)."""
    return "".join(c if c.isprintable() else "?" for c in str(s))


def scene_name(scene):
    name = re.sub(r"[^A-Za-z0-9_.-]", "-", scene.name).lstrip(".")
    return name or "scene"


def cache_dir(scene):
    """The cache folder, absolute. A folder relative to the .blend file needs a saved file."""
    raw = scene.wetcloth.cache_dir or "//wetcloth_cache/"
    if raw.startswith("//") and not bpy.data.filepath:
        raise ExportError(
            "The cache folder is relative to the .blend file (" + raw + "), which is not saved yet: "
            "save the file or set an absolute cache folder",
            key="cache_dir",
        )
    return os.path.normpath(bpy.path.abspath(raw))


def check_cache_dir_unshared(scene, folder):
    """Refuses a cache folder that another scene of the file with a cloth also uses: each bake
    replaces the folder's run and cache, which the other scene's cloth would then play."""
    for other in bpy.data.scenes:
        if other == scene or not any(o.wetcloth.role == "CLOTH" for o in other.objects):
            continue
        try:
            theirs = cache_dir(other)
        except ExportError:
            continue
        if theirs == folder:
            raise ExportError(
                f"The scene {other.name!r} uses the same cache folder ({folder}): give this scene its own "
                f"(Cache Folder), e.g. //wetcloth_cache_{scene_name(scene)}/",
                key="cache_dir",
            )


def frame_rate(scene):
    return scene.render.fps / scene.render.fps_base


def steps_per_frame(fps, time_step):
    """Steps in a frame: the time step rounded down so that a whole number fits."""
    return max(1, math.ceil((1.0 / fps) / max(time_step, 1e-12) * (1.0 - 1e-9)))


def find_cloth(scene):
    cloths = [o for o in scene.objects if o.wetcloth.role == "CLOTH"]
    if not cloths:
        raise ExportError("No cloth in this scene: set an object's Wet Cloth role to Cloth (Physics properties)", key="role")
    if len(cloths) > 1:
        names = ", ".join(sorted(o.name for o in cloths))
        raise ExportError(f"One cloth per scene: {names} are all marked Cloth", key="role", obj=cloths[1].name)
    cloth = cloths[0]
    if cloth.type != "MESH":
        raise ExportError(f"The cloth {cloth.name} is a {cloth.type.lower()}, not a mesh", key="role", obj=cloth.name)
    return cloth


def colliders(scene):
    """The scene's colliders, planes first (the first plane is the thesis model's sticking
    surface), then by name."""
    found = [o for o in scene.objects if o.wetcloth.role == "COLLIDER"]
    return sorted(found, key=lambda o: (o.wetcloth.collider_shape != "PLANE", o.name))


def _vertex_group_members(obj, name, what):
    vg = obj.vertex_groups.get(name)
    if vg is None:
        raise ExportError(f"{obj.name} has no vertex group {name!r} ({what})", key="pin_group", obj=obj.name)
    members = []
    for v in obj.data.vertices:
        for ge in v.groups:
            if ge.group == vg.index and ge.weight > 0.0:
                members.append(v.index)
                break
    if not members:
        raise ExportError(f"The vertex group {name!r} of {obj.name} ({what}) holds no vertex", key="pin_group", obj=obj.name)
    return members


def depsgraph(context, scene):
    """The evaluated state of ``scene``: the context's view layer when it is one of the scene's,
    else the scene's first (an operator run on another scene than the window's)."""
    view_layer = getattr(context, "view_layer", None)
    if view_layer is None or not any(v == view_layer for v in scene.view_layers):
        view_layer = scene.view_layers[0]
    if view_layer.depsgraph is None:
        view_layer.update()
    return view_layer.depsgraph


def _sample(context, scene, objects, frames):
    """World matrices (double-precision lists) of ``objects`` at each frame, as evaluated."""
    out = {o.name: [] for o in objects}
    if not objects:
        return out
    for f in frames:
        scene.frame_set(f)
        dg = depsgraph(context, scene)
        for o in objects:
            out[o.name].append(g.matrix(o.evaluated_get(dg).matrix_world))
    return out


def _dimensions(ob):
    """The bounding box's size along the object's own axes, scaled (``Object.dimensions``, but
    from the evaluated object's matrix, whatever its parents)."""
    bb = [tuple(b) for b in ob.bound_box]
    sizes = [max(p[k] for p in bb) - min(p[k] for p in bb) for k in range(3)]
    scale = g.scales(g.matrix(ob.matrix_world))
    return tuple(a * b for a, b in zip(sizes, scale))


def _keys_compact(keys):
    """Drops keys equal to both neighbours (a still stretch needs only its ends)."""
    if len(keys) <= 2:
        return keys
    kept = [keys[0]]
    for i in range(1, len(keys) - 1):
        if keys[i][1:] == keys[i - 1][1:] == keys[i + 1][1:]:
            continue
        kept.append(keys[i])
    kept.append(keys[-1])
    return kept


def _collider_keys(mats, times, pivot_local, box):
    """A collider's keys from its world matrices over the frames, or [] when it stays still.

    The shape is written at its first-frame pose (a box axis-aligned about its centre), and the
    command moves it as ``pivot + offset + R(turn) (x - pivot)``. Its motion from the first
    frame is the affine ``A(t) = C M(t) M(0)^-1 C^T`` (rigid while the scale is constant):
    ``offset = A(t) pivot - pivot`` and ``turn`` the Euler angles of A's rotation; a box's
    ``turn`` is its whole rotation, since its rest shape is axis-aligned."""
    m0 = mats[0]
    r0t = g.transpose3(g.rotation(m0))
    pivot0 = g.to_sim(g.apply(m0, pivot_local))
    keys = []
    prev = None
    moved = False
    scale_changes = False
    s0 = g.scales(m0)
    for j, (t, m) in enumerate(zip(times, mats)):
        pivot = g.to_sim(g.apply(m, pivot_local))
        offset = tuple(a - b for a, b in zip(pivot, pivot0))
        r = g.rotation(m)
        rel = r if box else g.mul3(r, r0t)
        turn = g.euler_xyz_degrees(g.rotation_to_sim(rel), prev)
        if j == 0 or m == m0:
            offset = (0.0, 0.0, 0.0)
            if not box:
                turn = (0.0, 0.0, 0.0)
        prev = turn
        if any(offset) or any(turn):
            moved = True
        if any(abs(a - b) > 1e-5 * max(a, b) for a, b in zip(g.scales(m), s0)):
            scale_changes = True
        keys.append((t, offset, turn))
    if not moved:
        return [], scale_changes
    return _keys_compact(keys), scale_changes


def _format_collider_keys(keys):
    items = [
        f"  {{ time = {fmt(t)}, offset = {vec(o)}, rotation = {vec(r)} }}," for t, o, r in keys
    ]
    return "keys = [\n" + "\n".join(items) + "\n]"


def _format_grab_keys(keys):
    items = [f"  {{ time = {fmt(t)}, offset = {vec(o)} }}," for t, o in keys]
    return "keys = [\n" + "\n".join(items) + "\n]"


def _write_obj(path, header, vertices, faces):
    tmp = path + ".part"
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write(f"# {comment(header)}\n")
        for v in vertices:
            f.write(f"v {fmt(v[0])} {fmt(v[1])} {fmt(v[2])}\n")
        for face in faces:
            f.write("f " + " ".join(str(i + 1) for i in face) + "\n")
    os.replace(tmp, path)


def _safe_file_name(name):
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name).lstrip(".") or "object"


def _value(cloth, prop, values):
    v = getattr(cloth.wetcloth, prop)
    if values is not None:
        return toml_string(v.lower())
    if isinstance(v, bool):
        return "true" if v else "false"
    return fmt32(v)


def export(context, scene=None):
    """Writes ``<cache_dir>/scene.toml`` with the cloth's and colliders' OBJ files and
    ``<cache_dir>/export.json`` (what turns the result back into Blender: the cloth's matrix,
    the frame mapping, which object each collider and grab came from). Returns that record.

    Leaves the scene at the frame it was on."""
    scene = scene or context.scene
    cloth = find_cloth(scene)
    s = cloth.wetcloth
    folder = cache_dir(scene)
    check_cache_dir_unshared(scene, folder)
    os.makedirs(os.path.join(folder, "colliders"), exist_ok=True)
    fps = frame_rate(scene)
    fs, fe = scene.frame_start, scene.frame_end
    if fe <= fs:
        raise ExportError(f"The scene's frame range {fs}-{fe} is empty: the end must be after the start", key="frame_range")
    frames = list(range(fs, fe + 1))
    times = [(f - fs) / fps for f in frames]
    duration = (fe - fs) / fps
    # A whole number of steps per frame, so that every frame lands on a step.
    time_step = 1.0 / (fps * steps_per_frame(fps, s.time_step))

    cols = colliders(scene)
    for c in cols:
        if c == cloth:
            raise ExportError(f"{c.name} is both the cloth and a collider", key="role", obj=c.name)
    hands = [(h.vertex_group, h.target) for h in s.hands]
    for vg, target in hands:
        if target is None:
            raise ExportError(f"A hand of {cloth.name} (group {vg!r}) has no target object", key="hands", obj=cloth.name)
    tracked = {o.name: o for o in cols}
    for _, target in hands:
        tracked[target.name] = target
    frame_before = scene.frame_current
    subframe_before = scene.frame_subframe
    try:
        scene.frame_set(fs)
        dg = depsgraph(context, scene)
        cloth_matrix = g.matrix(cloth.evaluated_get(dg).matrix_world)
        collider_meshes = {}
        for c in cols:
            if c.wetcloth.collider_shape == "MESH":
                ev = c.evaluated_get(dg)
                try:
                    me = ev.to_mesh()
                except RuntimeError:
                    me = None
                if me is None or len(me.polygons) == 0:
                    if me is not None:
                        ev.to_mesh_clear()
                    raise ExportError(
                        f"The collider {c.name} has no faces to write as a mesh: give it a mesh or choose Plane, Sphere or Box",
                        key="collider_shape", obj=c.name,
                    )
                collider_meshes[c.name] = (
                    [tuple(v.co) for v in me.vertices],
                    [tuple(p.vertices) for p in me.polygons],
                    [tuple(b) for b in c.bound_box],
                )
                ev.to_mesh_clear()
        bounds = {c.name: [tuple(b) for b in c.evaluated_get(dg).bound_box] for c in cols}
        dims = {c.name: _dimensions(c.evaluated_get(dg)) for c in cols}
        samples = _sample(context, scene, list(tracked.values()), frames)
    finally:
        scene.frame_set(frame_before, subframe=subframe_before)

    # --- the cloth -------------------------------------------------------------------------------
    mesh = cloth.data
    if len(mesh.polygons) == 0:
        raise ExportError(f"The cloth {cloth.name} has no faces", key="role", obj=cloth.name)
    cloth_vertices = [g.to_sim(g.apply(cloth_matrix, tuple(v.co))) for v in mesh.vertices]
    cloth_faces = [tuple(p.vertices) for p in mesh.polygons]
    _write_obj(
        os.path.join(folder, "cloth.obj"),
        f"{cloth.name}: world space at frame {fs}, Y up (Blender's (x, y, z) as (x, z, -y)), vertex k = Blender vertex k",
        cloth_vertices,
        cloth_faces,
    )
    mirrored = g.det3(cloth_matrix) < 0.0

    lines = [
        f"# Written by the wetcloth Blender add-on: scene {comment(scene.name)!s} of {comment(os.path.basename(bpy.data.filepath) or 'an unsaved file')},",
        f"# Blender frames {fs}-{fe} at {fps:g} fps are wetcloth frames 0-{fe - fs}. Y up (Blender's (x, y, z) is (x, z, -y)).",
        f"name = {toml_string(scene_name(scene))}",
    ]
    if not cols:
        lines.append("collider = []  # no colliders (not even the default ground)")
    lines += ["", "[simulation]", f"duration = {fmt(duration)}", f"frame_rate = {fmt(fps)}", f"time_step = {fmt(time_step)}"]
    gravity = g.to_sim(tuple(scene.gravity)) if scene.use_gravity else (0.0, 0.0, 0.0)
    by_table = {"simulation": [], "cloth": [], "air": []}
    for prop, table, key, values in PARAMETERS:
        if prop == "time_step":
            continue
        v = _value(cloth, prop, values)
        if prop == "flip_normals":
            v = "true" if (s.flip_normals != mirrored) else "false"
        by_table[table].append(f"{key} = {v}")
    lines += by_table["simulation"]
    lines.append(f"gravity = [{', '.join(fmt32(c) for c in gravity)}]")
    lines += ["", "[cloth]", f"# {comment(cloth.name)}", 'mesh = "cloth.obj"'] + by_table["cloth"]
    lines += ["", "[air]"] + by_table["air"]

    record_colliders = []
    warnings = []
    for i, c in enumerate(cols):
        shape = c.wetcloth.collider_shape
        mats = samples[c.name]
        m0 = mats[0]
        bb = bounds[c.name]
        bb_center = tuple((min(p[k] for p in bb) + max(p[k] for p in bb)) / 2 for k in range(3))
        lines += ["", "[[collider]]", f"# {comment(c.name)}"]
        if shape == "PLANE":
            pivot_local = (0.0, 0.0, 0.0)
            normal = g.to_sim(g.apply_linear(g.rotation(m0), (0.0, 0.0, 1.0)))
            lines += ['shape = "plane"', f"point = {vec(g.to_sim(g.apply(m0, pivot_local)))}", f"normal = {vec(normal)}"]
        elif shape == "SPHERE":
            pivot_local = bb_center
            radius = max(dims[c.name]) / 2
            if radius <= 0:
                raise ExportError(f"The sphere collider {c.name} has no size", key="collider_shape", obj=c.name)
            if min(dims[c.name]) < 0.99 * max(dims[c.name]):
                warnings.append(f"{c.name}: not round; written as a sphere of radius {radius:.4g} m")
            lines += ['shape = "sphere"', f"center = {vec(g.to_sim(g.apply(m0, pivot_local)))}", f"radius = {fmt(radius)}"]
        elif shape == "BOX":
            pivot_local = bb_center
            d = dims[c.name]
            half = (d[0] / 2, d[2] / 2, d[1] / 2)
            if min(half) <= 0:
                raise ExportError(f"The box collider {c.name} is flat (dimensions {d[0]:.4g} x {d[1]:.4g} x {d[2]:.4g})", key="collider_shape", obj=c.name)
            lines += ['shape = "box"', f"center = {vec(g.to_sim(g.apply(m0, pivot_local)))}", f"half_extents = {vec(half)}"]
        else:
            pivot_local = (0.0, 0.0, 0.0)
            verts, faces, _ = collider_meshes[c.name]
            origin = g.apply(m0, pivot_local)
            world = [g.to_sim(tuple(a - b for a, b in zip(g.apply(m0, v), origin))) for v in verts]
            fname = f"colliders/{i}-{_safe_file_name(c.name)}.obj"
            _write_obj(
                os.path.join(folder, fname),
                f"{c.name}: evaluated mesh at frame {fs}, world axes, Y up, about the object's origin",
                world,
                faces,
            )
            lines += ['shape = "mesh"', f"file = {toml_string(fname)}", f"position = {vec(g.to_sim(origin))}"]
            mods = [m.type for m in c.modifiers if m.show_render]
            if "ARMATURE" in mods or (c.data is not None and getattr(c.data, "shape_keys", None)):
                warnings.append(f"{c.name}: deforms; its mesh is taken as at frame {fs}")
        keys, scale_changes = _collider_keys(mats, times, pivot_local, box=(shape == "BOX"))
        if scale_changes:
            warnings.append(f"{c.name}: its scale changes; only its motion and turning are followed")
        lines += [f"friction = {fmt32(c.wetcloth.friction)}", f"sticky = {'true' if c.wetcloth.sticky else 'false'}"]
        if keys:
            lines.append(_format_collider_keys(keys))
        record_colliders.append({"object": c.name, "shape": shape.lower(), "moving": bool(keys)})

    # --- pins and hands ----------------------------------------------------------------------------
    record_grabs = []
    held = set()
    hand_lines = []
    for vg, target in hands:
        members = _vertex_group_members(cloth, vg, f"the hand following {target.name}")
        mats = samples[target.name]
        inv0 = g.inverse(mats[0])
        for k in members:
            if k in held:
                continue
            held.add(k)
            p_world = g.apply(cloth_matrix, tuple(mesh.vertices[k].co))
            local = g.apply(inv0, p_world)
            p0 = g.to_sim(p_world)
            keys = []
            for j, (t, m) in enumerate(zip(times, mats)):
                if j == 0:
                    keys.append((t, (0.0, 0.0, 0.0)))
                    continue
                p = g.to_sim(g.apply(m, local))
                keys.append((t, tuple(a - b for a, b in zip(p, p0))))
            hand_lines += ["", "[[grab]]", f"# hand: group {comment(vg)}, following {comment(target.name)}", f"vertex = {k}"]
            hand_lines.append(_format_grab_keys(_keys_compact(keys)))
            record_grabs.append({"kind": "hand", "vertex_group": vg, "target": target.name, "vertex": k})
    pin_lines = []
    if s.pin_group:
        for k in _vertex_group_members(cloth, s.pin_group, "the pin group"):
            if k in held:
                continue
            held.add(k)
            pin_lines += ["", "[[grab]]", f"# pinned: group {comment(s.pin_group)}", f"vertex = {k}",
                          "keys = [{ time = 0.0, offset = [0.0, 0.0, 0.0] }]"]
            record_grabs.append({"kind": "pin", "vertex_group": s.pin_group, "vertex": k})
    # Hands first, then pins: the order of record_grabs, which names grab[i] in messages.
    lines += hand_lines + pin_lines

    scene_path = os.path.join(folder, "scene.toml")
    tmp = scene_path + ".part"
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, scene_path)

    record = {
        "scene": scene.name,
        "name": scene_name(scene),
        "cloth": cloth.name,
        "vertices": len(mesh.vertices),
        "matrix_world": cloth_matrix,
        "frame_start": fs,
        "frame_end": fe,
        "fps": fps,
        "frames": fe - fs + 1,
        "time_step": time_step,
        "colliders": record_colliders,
        "grabs": record_grabs,
        "warnings": warnings,
    }
    rec_path = os.path.join(folder, "export.json")
    with open(rec_path + ".part", "w", encoding="utf-8") as f:
        json.dump(record, f, indent=1)
    os.replace(rec_path + ".part", rec_path)
    return record
