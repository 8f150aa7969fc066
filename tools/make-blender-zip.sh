#!/usr/bin/env bash
# Builds the Blender add-on's zip: blender/wetcloth_blender/ as a top-level folder, installable
# with Edit > Preferences > Add-ons > Install (Blender 3.4 to 4.x) and as an extension from disk
# (Blender 4.2 and later, which reads its blender_manifest.toml).
#
#     tools/make-blender-zip.sh [OUT.zip]       default: target/wetcloth_blender.zip
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-target/wetcloth_blender.zip}"
mkdir -p "$(dirname "$out")"
python3 - "$out" <<'PY'
import os, sys, zipfile
out = sys.argv[1]
root = "blender"
tmp = out + ".part"
with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
    for folder, dirs, files in os.walk(os.path.join(root, "wetcloth_blender")):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith((".pyc", ".pyo")):
                continue
            path = os.path.join(folder, name)
            # Fixed times, so the same sources make the same zip.
            info = zipfile.ZipInfo(os.path.relpath(path, root), date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            with open(path, "rb") as f:
                z.writestr(info, f.read())
os.replace(tmp, out)
print(out)
PY
