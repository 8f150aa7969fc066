"""Operators: wetcloth.export, .bake, .resume, .cancel, .load, .free (and the hand list's add
and remove). They act on the context's scene and its one cloth object, from any editor or from
a script (``bpy.ops.wetcloth.bake()``). With a window, Bake and Resume run in the background
with a progress bar (panel and status bar) and stop on Escape or Cancel; in background mode
(``blender -b``), or with ``blocking=True``, they wait for the run.
"""

import json
import os

import bpy
from bpy.props import BoolProperty

from . import cache, runner, scene_export


def _clear_error(scene):
    s = scene.wetcloth
    s.last_error = ""
    s.last_error_key = ""
    s.last_error_object = ""


def _fail(op, scene, e):
    """Records an error in the scene (the panel shows it) and reports it (a script gets a
    RuntimeError from bpy.ops)."""
    s = scene.wetcloth
    s.last_error = str(e)
    s.last_error_key = getattr(e, "key", "")
    s.last_error_object = getattr(e, "obj", "")
    s.status = ""
    op.report({"ERROR"}, str(e))
    return {"CANCELLED"}


def _redraw(context):
    wm = context.window_manager
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in ("PROPERTIES", "VIEW_3D", "STATUSBAR"):
                area.tag_redraw()


def _set_status_bar(context, text):
    ws = getattr(context, "workspace", None)
    if ws is not None:
        try:
            ws.status_text_set(text)
        except (AttributeError, TypeError):
            pass


class _SceneOperator:
    @classmethod
    def poll(cls, context):
        return context.scene is not None


class WETCLOTH_OT_export(_SceneOperator, bpy.types.Operator):
    """Write the scene for the wetcloth command (scene.toml and OBJ files) into the cache folder"""

    bl_idname = "wetcloth.export"
    bl_label = "Export Scene"
    bl_options = {"REGISTER"}

    def execute(self, context):
        scene = context.scene
        _clear_error(scene)
        try:
            record = scene_export.export(context, scene)
        except (scene_export.ExportError, OSError, ValueError) as e:
            return _fail(self, scene, e)
        folder = scene_export.cache_dir(scene)
        scene.wetcloth.status = f"Exported {record['frames']} frames to {os.path.join(folder, 'scene.toml')}"
        for w in record["warnings"]:
            self.report({"WARNING"}, w)
        self.report({"INFO"}, scene.wetcloth.status)
        return {"FINISHED"}


class _RunOperator(_SceneOperator):
    """Shared by Bake and Resume: starts a run, then waits (background) or polls (modal)."""

    blocking: BoolProperty(
        name="Wait",
        description="Wait for the run to end instead of running it in the background",
        default=False,
        options={"SKIP_SAVE"},
    )
    _timer = None
    _job = None
    _scene_name = ""

    mode = "bake"

    def prepare(self, context, scene, cloth):
        raise NotImplementedError

    def execute(self, context):
        scene = context.scene
        if runner.job_of(scene) is not None:
            self.report({"ERROR"}, "A bake of this scene is already running: cancel it first")
            return {"CANCELLED"}
        _clear_error(scene)
        try:
            cloth = scene_export.find_cloth(scene)
            job = self.prepare(context, scene, cloth)
        except (scene_export.ExportError, runner.BakeError, cache.CacheError, OSError, ValueError) as e:
            return _fail(self, scene, e)
        scene.wetcloth.progress = 0.0
        scene.wetcloth.status = "Baking..." if self.mode == "bake" else "Resuming..."
        self._scene_name = scene.name
        if self.blocking or bpy.app.background or context.window is None:
            runner.wait(job)
            return self.done(context, scene, cloth, job)
        self._job = job
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.modal_handler_add(self)
        self.update(context, scene, job)
        return {"RUNNING_MODAL"}

    def invoke(self, context, event):
        return self.execute(context)

    def update(self, context, scene, job):
        done = job.frames()
        scene.wetcloth.progress = 100.0 * done / max(1, job.total)
        verb = "Baking" if job.mode == "bake" else "Resuming"
        text = f"wetcloth: {verb} frame {done} of {job.total} (Esc to stop)"
        scene.wetcloth.status = text
        _set_status_bar(context, text)
        _redraw(context)

    def modal(self, context, event):
        job = self._job
        scene = bpy.data.scenes.get(self._scene_name)
        if scene is None:  # the scene went away: stop the run
            runner.cancel(job.scene_name)
        if event.type == "ESC" and event.value == "PRESS":
            runner.cancel(job.scene_name)
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if job.running():
            if scene is not None:
                self.update(context, scene, job)
            return {"PASS_THROUGH"}
        context.window_manager.event_timer_remove(self._timer)
        self._timer = None
        _set_status_bar(context, None)
        if scene is None:
            runner.finish_abandoned(job)
            return {"CANCELLED"}
        try:
            cloth = scene_export.find_cloth(scene)
        except scene_export.ExportError as e:
            runner.finish_abandoned(job)
            return _fail(self, scene, e)
        result = self.done(context, scene, cloth, job)
        _redraw(context)
        return result

    def done(self, context, scene, cloth, job):
        try:
            level, message = runner.finish(job, scene, cloth)
        except runner.BakeError as e:
            scene.wetcloth.progress = 0.0
            return _fail(self, scene, e)
        scene.wetcloth.progress = 100.0 * job.frames() / max(1, job.total) if level != "INFO" else 100.0
        scene.wetcloth.status = message
        self.report({level}, message)
        return {"FINISHED"}


class WETCLOTH_OT_bake(_RunOperator, bpy.types.Operator):
    """Export the scene, run it with the wetcloth command and play the result on the cloth"""

    bl_idname = "wetcloth.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER"}
    mode = "bake"

    def prepare(self, context, scene, cloth):
        cache.free(cloth)
        folder = scene_export.cache_dir(scene)
        bake_json = os.path.join(folder, "bake.json")
        previous = None
        if os.path.exists(bake_json):
            try:
                previous = cache.read_json(bake_json)
            except (OSError, ValueError):
                previous = None
        record = scene_export.export(context, scene)
        for w in record["warnings"]:
            self.report({"WARNING"}, w)
        with open(bake_json + ".part", "w", encoding="utf-8") as f:
            json.dump(record, f, indent=1)
        os.replace(bake_json + ".part", bake_json)
        job = runner.start(scene, folder, "bake", record)
        job.previous_record = previous
        return job


class WETCLOTH_OT_resume(_RunOperator, bpy.types.Operator):
    """Continue the stopped run from its last checkpoint and play the whole result"""

    bl_idname = "wetcloth.resume"
    bl_label = "Resume"
    bl_options = {"REGISTER"}
    mode = "resume"

    def prepare(self, context, scene, cloth):
        folder = scene_export.cache_dir(scene)
        if not runner.resumable(folder):
            status, frames = runner.run_state(folder)
            why = f"the run says {status!r} after {frames} frames" if status else "there is no run"
            raise runner.BakeError(f"Nothing to resume in {folder}: {why}")
        record = cache.read_json(os.path.join(folder, "bake.json"))
        return runner.start(scene, folder, "resume", record)


class WETCLOTH_OT_cancel(_SceneOperator, bpy.types.Operator):
    """Stop the running bake after its current frame; the frames so far are loaded and Resume continues"""

    bl_idname = "wetcloth.cancel"
    bl_label = "Cancel"
    bl_options = {"REGISTER"}

    def execute(self, context):
        if not runner.cancel(context.scene):
            self.report({"WARNING"}, "No bake of this scene is running")
            return {"CANCELLED"}
        self.report({"INFO"}, "Stopping the bake after its current frame")
        return {"FINISHED"}


class WETCLOTH_OT_load(_SceneOperator, bpy.types.Operator):
    """Play the run in the cache folder on the cloth (a Mesh Cache modifier, first on the object)"""

    bl_idname = "wetcloth.load"
    bl_label = "Load"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = context.scene
        if runner.job_of(scene) is not None:
            self.report({"ERROR"}, "A bake of this scene is running: it loads its result when it ends")
            return {"CANCELLED"}
        _clear_error(scene)
        try:
            cloth = scene_export.find_cloth(scene)
            folder = scene_export.cache_dir(scene)
            frames, info = cache.load(scene, folder, cloth)
        except (scene_export.ExportError, cache.CacheError, OSError, ValueError, KeyError) as e:
            return _fail(self, scene, e)
        status = info.get("status", "")
        if status == "complete":
            message = f"Loaded {frames} frames"
        else:
            message = f"Loaded the {frames} frames the run wrote before it stopped ({status})"
        scene.wetcloth.status = message
        self.report({"INFO"}, message)
        return {"FINISHED"}


class WETCLOTH_OT_free(_SceneOperator, bpy.types.Operator):
    """Remove the cache modifier from the cloth (the files in the cache folder stay)"""

    bl_idname = "wetcloth.free"
    bl_label = "Free"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = context.scene
        try:
            cloth = scene_export.find_cloth(scene)
        except scene_export.ExportError as e:
            return _fail(self, scene, e)
        if cache.free(cloth):
            scene.wetcloth.status = "Freed: the cloth shows its own mesh; the files stay in the cache folder"
        else:
            scene.wetcloth.status = "Nothing was loaded"
        scene.wetcloth.progress = 0.0
        self.report({"INFO"}, scene.wetcloth.status)
        return {"FINISHED"}


class WETCLOTH_OT_hand_add(bpy.types.Operator):
    """Add a hand: a vertex group of the cloth that follows an object's animation"""

    bl_idname = "wetcloth.hand_add"
    bl_label = "Add Hand"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def execute(self, context):
        s = context.object.wetcloth
        s.hands.add()
        s.active_hand = len(s.hands) - 1
        return {"FINISHED"}


class WETCLOTH_OT_hand_remove(bpy.types.Operator):
    """Remove the selected hand"""

    bl_idname = "wetcloth.hand_remove"
    bl_label = "Remove Hand"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and len(context.object.wetcloth.hands) > 0

    def execute(self, context):
        s = context.object.wetcloth
        s.hands.remove(s.active_hand)
        s.active_hand = max(0, min(s.active_hand, len(s.hands) - 1))
        return {"FINISHED"}


classes = (
    WETCLOTH_OT_export,
    WETCLOTH_OT_bake,
    WETCLOTH_OT_resume,
    WETCLOTH_OT_cancel,
    WETCLOTH_OT_load,
    WETCLOTH_OT_free,
    WETCLOTH_OT_hand_add,
    WETCLOTH_OT_hand_remove,
)


@bpy.app.handlers.persistent
def _stop_runs_on_load(_dummy):
    runner.stop_all()


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.app.handlers.load_pre.append(_stop_runs_on_load)


def unregister():
    if _stop_runs_on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_stop_runs_on_load)
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
