"""Runs the `wetcloth` command for a scene in the background and reads how far it got.

One run per Blender scene at a time. ``start`` launches ``wetcloth run`` (or ``--resume``) with
its output in a log file; ``progress`` reads the run's ``run.json`` (frames written, rewritten
after every frame); ``cancel`` sends SIGTERM, which stops the run after a whole frame with a
checkpoint (exit 130, ``run.json`` "interrupted"), so the frames so far play and ``--resume``
continues; ``finish`` loads what was written and turns the command's error message into one
that names the object and the scene key.

Nothing here touches bpy while a run is going except through the callers (the modal operator
on the main thread, or the blocking loop in background mode); ``cancel`` may be called from any
thread.
"""

import atexit
import json
import os
import re
import shutil
import subprocess
import time

import bpy

from . import cache
from .props import PROPERTY_OF_KEY

_jobs = {}


class BakeError(Exception):
    def __init__(self, message, key="", obj=""):
        super().__init__(message)
        self.key = key
        self.obj = obj


def _prefs():
    addon = bpy.context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def find_cli(quiet=False):
    """The wetcloth program: the preference ``cli_path``, else ``wetcloth`` on PATH."""
    prefs = _prefs()
    path = bpy.path.abspath(prefs.cli_path) if prefs and prefs.cli_path else ""
    if path:
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
        if quiet:
            return None
        raise BakeError(f"The wetcloth command set in the add-on's preferences does not run: {path}", key="cli_path")
    found = shutil.which("wetcloth")
    if found or quiet:
        return found
    raise BakeError(
        "The wetcloth command is not on PATH: install it (cargo install --path crates/wetcloth-cli) "
        "or set its path in the add-on's preferences",
        key="cli_path",
    )


class Job:
    def __init__(self, scene_name, cache_dir, mode, proc, log, total):
        self.scene_name = scene_name
        self.cache_dir = cache_dir
        self.run_dir = os.path.join(cache_dir, "run")
        self.mode = mode
        self.proc = proc
        self.log = log
        self.total = total
        self.cancelled = False
        self.started = time.monotonic()
        self.started_wall = time.time()
        self.previous_record = None

    def frames(self):
        """Frames written so far (run.json's count; 0 before it is there)."""
        try:
            with open(os.path.join(self.run_dir, "run.json"), encoding="utf-8") as f:
                info = json.load(f)
        except (OSError, ValueError):
            return 0
        if self.mode == "bake" and os.path.getmtime(os.path.join(self.run_dir, "run.json")) < self.started_wall - 0.05:
            return 0  # still the earlier run's record
        return int(info.get("frames", 0))

    def running(self):
        return self.proc.poll() is None


def job_of(scene):
    """The scene's job (running, or ended and not yet finished by its caller), or None."""
    return _jobs.get(scene if isinstance(scene, str) else scene.name)


def cancel(scene):
    """Asks the scene's run to stop after its current frame. Safe from any thread."""
    job = _jobs.get(scene if isinstance(scene, str) else scene.name)
    if job is None or not job.running():
        return False
    job.cancelled = True
    job.proc.terminate()
    return True


def stop_all():
    for job in list(_jobs.values()):
        if job.running():
            job.cancelled = True
            job.proc.terminate()
    for job in list(_jobs.values()):
        try:
            job.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            job.proc.kill()
    _jobs.clear()


# A run still going when Blender quits is stopped (after a whole frame, resumable), not orphaned.
atexit.register(stop_all)


def start(scene, cache_dir, mode, record):
    """Launches the command. ``mode``: "bake" (the exported scene.toml into run/) or "resume"."""
    key = scene.name
    if key in _jobs:
        raise BakeError("A bake of this scene is already running: cancel it first")
    cli = find_cli()
    run_dir = os.path.join(cache_dir, "run")
    if mode == "bake":
        argv = [cli, "run", os.path.join(cache_dir, "scene.toml"), "--out", run_dir]
    else:
        argv = [cli, "run", "--resume", run_dir]
    argv += ["--export", "pc2", "--quiet"]
    log_path = os.path.join(cache_dir, "run.log")
    log = open(log_path, "w", encoding="utf-8")
    log.write("$ " + " ".join(argv) + "\n")
    log.flush()
    try:
        proc = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, cwd=cache_dir)
    except OSError as e:
        log.close()
        raise BakeError(f"Could not start {cli}: {e}", key="cli_path")
    job = Job(key, cache_dir, mode, proc, log, record["frames"])
    _jobs[key] = job
    return job


def wait(job, report=print):
    """Blocks until the run ends (background mode), saying how far it got now and then."""
    shown = -1
    while job.proc.poll() is None:
        time.sleep(0.05)
        done = job.frames()
        tenth = 10 * done // max(1, job.total)
        if tenth != shown:
            shown = tenth
            report(f"wetcloth: frame {done} of {job.total}")


_LOCATED = re.compile(r"^(?P<file>.+?\.(?:toml|obj)):(?P<line>\d+)(?::(?P<col>\d+))?: (?P<rest>.*)$")
_KEY = re.compile(r"^(?P<key>[A-Za-z_]\w*(?:\[\d+\])?(?:\.[A-Za-z_]\w*(?:\[\d+\])?)*)(?: = |: )")


def _error_line(text):
    for line in text.splitlines():
        if line.startswith("error: "):
            return line[len("error: "):].strip()
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("$ ")]
    return lines[-1].strip() if lines else ""


def explain(text, record, cloth_name):
    """(message, scene key, object name) for the command's error output ``text``."""
    msg = _error_line(text) or "the wetcloth command failed without a message"
    loc = _LOCATED.match(msg)
    rest = loc.group("rest") if loc else msg
    m = _KEY.match(rest)
    key = m.group("key") if m else ""
    obj = ""
    if loc and loc.group("file").endswith(".obj") and not key:
        name = os.path.basename(loc.group("file"))
        key = "cloth.mesh" if name.startswith("cloth") else "collider"
    top = re.match(r"^(collider|grab)\[(\d+)\]", key)
    if top:
        i = int(top.group(2))
        items = record.get("colliders" if top.group(1) == "collider" else "grabs", [])
        if i < len(items):
            item = items[i]
            if top.group(1) == "collider":
                obj = item["object"]
            else:
                obj = cloth_name
                what = f"the hand following {item['target']}" if item["kind"] == "hand" else "the pin group"
                rest = f"{rest} ({what} {item['vertex_group']!r}, vertex {item['vertex']})"
    elif key.split(".")[0] in ("cloth", "air", "simulation") or key in PROPERTY_OF_KEY:
        obj = cloth_name
    where = f"{obj}: " if obj else ""
    if loc:
        rest = f"{rest} [scene.toml line {loc.group('line')}]" if loc.group("file").endswith(".toml") else f"{rest} [{os.path.basename(loc.group('file'))} line {loc.group('line')}]"
    return where + rest, key, obj


def read_log(job):
    try:
        job.log.close()
    except OSError:
        pass
    try:
        with open(os.path.join(job.cache_dir, "run.log"), encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return ""


def finish(job, scene, cloth):
    """Ends the job: loads what the run wrote onto ``cloth``. Returns (level, message), level
    'INFO' or 'WARNING'; raises BakeError when the run wrote nothing to load."""
    _jobs.pop(job.scene_name, None)
    rc = job.proc.wait()
    text = read_log(job)
    bake_json = os.path.join(job.cache_dir, "bake.json")
    record = cache.read_json(bake_json) if os.path.exists(bake_json) else {}
    try:
        info = cache.read_json(os.path.join(job.run_dir, "run.json"))
    except (OSError, ValueError):
        info = {}
    status = info.get("status", "")
    frames = int(info.get("frames", 0)) if status else 0
    if rc == 2:
        # Refused before anything was written: the earlier bake (if any) stays as it was.
        if job.mode == "bake" and job.previous_record is not None:
            with open(bake_json, "w", encoding="utf-8") as f:
                json.dump(job.previous_record, f, indent=1)
        message, key, obj = explain(text, record, cloth.name)
        raise BakeError(message, key, obj)
    if frames == 0:
        if job.cancelled:
            raise BakeError("Cancelled before the first frame: nothing to load")
        message, key, obj = explain(text, record, cloth.name)
        raise BakeError(message, key, obj)
    try:
        loaded, _ = cache.load(scene, job.cache_dir, cloth)
    except (cache.CacheError, OSError, ValueError) as e:
        raise BakeError(str(e))
    total = record.get("frames", job.total)
    if rc == 0 and status == "complete":
        warnings = [ln[len("warning: "):] for ln in text.splitlines() if ln.startswith("warning: ")]
        note = f" (warning: {warnings[0]})" if warnings else ""
        return "INFO", f"Baked {loaded} frames in {time.monotonic() - job.started:.1f} s{note}"
    if job.cancelled or rc == 130 or rc < 0:
        return "WARNING", f"Stopped at {loaded} of {total} frames; they are loaded. Resume continues the run"
    message, key, obj = explain(text, record, cloth.name)
    raise BakeError(f"{message} (the {loaded} frames before it are loaded)", key, obj)


def finish_abandoned(job):
    """Forgets a job whose scene or cloth went away (its files stay)."""
    _jobs.pop(job.scene_name, None)
    job.proc.wait()
    read_log(job)


def resumable(cache_dir):
    """Whether the run in ``cache_dir/run`` was stopped and can be continued."""
    try:
        info = cache.read_json(os.path.join(cache_dir, "run", "run.json"))
    except (OSError, ValueError):
        return False
    return info.get("status") != "complete" and "checkpoint" in info and os.path.exists(
        os.path.join(cache_dir, "run", "checkpoint.bin")
    )


def run_state(cache_dir):
    """(status, frames) of the run in ``cache_dir/run``, or ("", 0)."""
    try:
        info = cache.read_json(os.path.join(cache_dir, "run", "run.json"))
    except (OSError, ValueError):
        return "", 0
    return info.get("status", ""), int(info.get("frames", 0))
