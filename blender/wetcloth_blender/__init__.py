"""wetcloth for Blender: wet cloth that sticks, simulated by the `wetcloth` command.

Marks one mesh object of a scene as the cloth and others as colliders (Physics properties),
writes the scene for the `wetcloth` command (scene.toml and OBJ files, Blender's Z-up turned into
wetcloth's Y-up), runs it in the background and plays the result on the cloth object through a
Mesh Cache modifier (PC2, in the object's own space). See docs/blender.md in the wetcloth
repository.

Installs from a zip as an add-on on Blender 3.4 to 4.x (``bl_info``) and as an extension on 4.2
and later (``blender_manifest.toml``). Pure Python: it needs no compiled module and no numpy.
"""

bl_info = {
    "name": "wetcloth",
    "author": "wetcloth developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Physics > Wet Cloth",
    "description": "Wet cloth that sticks (trapped air, water film), simulated by the wetcloth command",
    "doc_url": "",
    "category": "Physics",
}

if "props" in locals():
    import importlib

    for _m in (geometry, props, scene_export, cache, runner, ops, ui):  # noqa: F821
        importlib.reload(_m)

from . import geometry, props, scene_export, cache, runner, ops, ui  # noqa: E402,F401

_modules = (props, ops, ui)


def register():
    for m in _modules:
        m.register()


def unregister():
    runner.stop_all()
    for m in reversed(_modules):
        m.unregister()

