"""The pictures of docs/blender.md: the add-on's panels in Blender's UI, during and after a bake
(the bake started as an artist starts it: Bake in the panel, running in the background), and a
frame of the result rendered with Cycles.

    xvfb-run -a -s "-screen 0 760x1640x24" blender --factory-startup --python tools/blender_addon_pictures.py -- \
        --zip target/wetcloth_blender.zip --wetcloth target/release/wetcloth --out docs/images --work /tmp/shots

Writes OUT/blender-panel-error.png (a cloth starting inside the ball, refused),
OUT/blender-panel-baking.png, OUT/blender-panel.png, OUT/blender-collider.png and
OUT/blender-render.png, then quits. The panel pictures are cropped with ImageMagick's `convert`
when it is there. Tested with Blender 3.4 (Debian's `blender`) under Xvfb.
"""

import importlib
import math
import os
import shutil
import subprocess
import sys

import bmesh
import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
ZIP, BIN, OUT, WORK = (os.path.abspath(argv[argv.index(k) + 1]) for k in ("--zip", "--wetcloth", "--out", "--work"))
os.makedirs(OUT, exist_ok=True)
os.makedirs(WORK, exist_ok=True)

bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
bpy.ops.preferences.addon_enable(module="wetcloth_blender")
runner = importlib.import_module("wetcloth_blender.runner")
bpy.context.preferences.addons["wetcloth_blender"].preferences.cli_path = BIN
bpy.context.preferences.view.show_splash = False


def build():
    scene = bpy.context.scene
    for ob in list(scene.objects):
        if ob.type == "MESH":
            bpy.data.objects.remove(ob)
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, 37
    me = bpy.data.meshes.new("Towel")
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.2)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=38, use_grid_fill=True)
    bm.to_mesh(me)
    bm.free()
    towel = bpy.data.objects.new("Towel", me)
    scene.collection.objects.link(towel)
    towel.location = (0.0, 0.0, 0.13)
    towel.rotation_euler.z = math.radians(20)
    towel.wetcloth.role = "CLOTH"
    towel.wetcloth.mass = 0.05
    # A hand holds a corner from the start (the towel hangs from it over the ball onto the
    # table), then lifts it 7 cm.
    lift = towel.vertex_groups.new(name="lift")
    lift.add([v.index for v in me.vertices if v.co.x > 0.185 and v.co.y > 0.185], 1.0, "REPLACE")
    hand = bpy.data.objects.new("Hand", None)
    scene.collection.objects.link(hand)
    hand.empty_display_size = 0.03
    for frame, z in ((19, 0.0), (37, 0.07)):
        hand.location = (0.0, 0.0, z)
        hand.keyframe_insert("location", frame=frame)
    h = towel.wetcloth.hands.add()
    h.vertex_group, h.target = "lift", hand

    def solid(name, maker, location, shape, friction=0.6):
        me = bpy.data.meshes.new(name)
        bm = bmesh.new()
        maker(bm)
        bm.to_mesh(me)
        bm.free()
        ob = bpy.data.objects.new(name, me)
        scene.collection.objects.link(ob)
        ob.location = location
        ob.wetcloth.role = "COLLIDER"
        ob.wetcloth.collider_shape = shape
        ob.wetcloth.friction = friction
        for p in me.polygons:
            p.use_smooth = True
        return ob

    ball = solid("Ball", lambda bm: bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=0.07), (0.0, 0.02, 0.05), "SPHERE")
    table = solid("Table", lambda bm: bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.6), (0.0, 0.0, 0.0), "PLANE")
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(WORK, "pictures.blend"))
    return scene, towel, ball, table


def properties_area():
    win = bpy.context.window_manager.windows[0]
    for area in win.screen.areas:
        if area.type == "PROPERTIES":
            return win, area
    raise RuntimeError("no Properties editor")


def show(ob):
    win, area = properties_area()
    for o in bpy.context.scene.objects:
        o.select_set(o == ob)
    bpy.context.view_layer.objects.active = ob
    area.spaces[0].context = "PHYSICS"


def shot(name, height=None):
    """The window, from below the top bar; ``height`` pixels of it, or down to the status bar."""
    win, area = properties_area()
    path = os.path.join(OUT, name)
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
        bpy.ops.screen.screenshot(filepath=path)
    if shutil.which("convert"):
        top = 52  # the top bar and the editor's header
        h = height or (win.height - top)
        subprocess.run(["convert", path, "-crop", f"{win.width}x{h}+0+{top}", "+repage", path], check=True)
    print("wrote", path, flush=True)


state = {"step": 0}


def enlarge_properties():
    """Gives the Properties editor the window's height and a readable width."""
    win, area = properties_area()
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.screen.screen_full_area()


def render(scene, towel, ball, table):
    scene.frame_set(scene.frame_end)
    for o, colour, rough in ((towel, (0.45, 0.05, 0.09, 1), 0.3), (ball, (0.75, 0.72, 0.65, 1), 0.5),
                             (table, (0.6, 0.6, 0.58, 1), 0.7)):
        mat = bpy.data.materials.new(o.name)
        mat.use_nodes = True
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = colour
        bsdf.inputs["Roughness"].default_value = rough
        o.data.materials.append(mat)
    for p in towel.data.polygons:
        p.use_smooth = True
    # The cloth's surface is the particles' centres; a thin shell along its normals.
    shell = towel.modifiers.new("thickness", "SOLIDIFY")
    shell.thickness, shell.offset = 0.0012, 1.0
    cam = bpy.data.objects.get("Camera")
    cam.location = (0.55, -0.62, 0.45)
    target = bpy.data.objects.new("target", None)
    scene.collection.objects.link(target)
    target.location = (0.0, 0.0, 0.03)
    track = cam.constraints.new("TRACK_TO")
    track.target = target
    cam.data.lens = 50
    scene.camera = cam
    light = bpy.data.objects.get("Light")
    light.data.type = "SUN"
    light.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
    light.data.energy = 3.0
    light.data.angle = math.radians(8)
    scene.world.color = (0.45, 0.48, 0.52)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 640, 400
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.filepath = os.path.join(OUT, "blender-render.png")
    bpy.ops.render.render(write_still=True)
    print("wrote", scene.render.filepath, flush=True)


def tick():
    s = state
    step = s["step"]
    s["step"] += 1
    if step == 0:
        s["objects"] = build()
        scene, towel = s["objects"][0], s["objects"][1]
        show(towel)
        enlarge_properties()
        return 0.5
    scene, towel, ball, table = s["objects"]
    if step == 1:
        # A mistake first: the ball raised into the cloth is refused, the panel says why.
        ball.location.z = 0.1
        try:
            bpy.ops.wetcloth.bake(blocking=True)
        except RuntimeError as e:  # the operator reports the error, as it should
            print("refused as expected:", str(e)[:80], flush=True)
        return 0.5
    if step == 2:
        shot("blender-panel-error.png", height=440)
        ball.location.z = 0.05
        return 0.2
    if step == 3:
        win, area = properties_area()
        region = next(r for r in area.regions if r.type == "WINDOW")
        with bpy.context.temp_override(window=win, screen=win.screen, area=area, region=region):
            bpy.ops.wetcloth.bake("INVOKE_DEFAULT")
        return 0.5
    job = runner.job_of(scene)
    if job is not None:
        if "baking" not in s and scene.wetcloth.progress >= 30:
            s["baking"] = True
            shot("blender-panel-baking.png", height=1100)
        return 0.3
    if "ended" not in s:
        s["ended"] = True  # let the panel settle (its sub-panels slide into place)
        print("bake:", scene.wetcloth.status, scene.wetcloth.last_error, flush=True)
        return 1.0
    if "done" not in s:
        s["done"] = True
        shot("blender-panel.png", height=1290)
        show(ball)
        return 0.5
    if "collider" not in s:
        s["collider"] = True
        shot("blender-collider.png", height=200)
        show(towel)
        return 0.5
    render(scene, towel, ball, table)
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(tick, first_interval=1.5)
