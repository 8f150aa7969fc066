#!/usr/bin/env bash
# Whether the viewer keeps real time while the thesis demo is pulled: runs `wetcloth view`
# (its default scene) under a virtual display with Mesa's software renderer, replays
# tools/viewer-pull.txt (the centre lifted 6.5 cm with the wheel, then dragged about) and prints
# the simulated seconds per wall second over the whole pull and over each half second.
#
#   tools/viewer-realtime.sh [extra `wetcloth view` arguments]
#
# Needs xvfb and mesa-vulkan-drivers (Debian). Builds the release binary first.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p wetcloth-cli
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
xvfb-run -a -s "-screen 0 1280x800x24" target/release/wetcloth view "$@" \
  --script tools/viewer-pull.txt --exit >"$out" 2>/dev/null
python3 - "$out" <<'PY'
import re, sys
rows = []
for line in open(sys.argv[1]):
    m = re.search(r"report wall ([\d.]+) s, simulated ([\d.]+) s, real-time factor ([\d.]+).*?"
                  r"([\d.]+) steps/s, ([\d.]+) frames/s, grab force (-?[\d.]+) N", line)
    if m:
        rows.append([float(g) for g in m.groups()])
if len(rows) < 2:
    sys.exit("no reports: did the viewer start? (run it by hand to see)")
print(f"{'wall s':>8} {'sim s':>8} {'rtf (0.5 s)':>11} {'rtf (since last)':>16} {'steps/s':>8} {'fps':>6} {'hand N':>8}")
for a, b in zip(rows, rows[1:]):
    rtf = (b[1] - a[1]) / max(b[0] - a[0], 1e-9)
    print(f"{b[0]:8.2f} {b[1]:8.3f} {b[2]:11.2f} {rtf:16.2f} {b[3]:8.0f} {b[4]:6.1f} {b[5]:8.3f}")
w, s = rows[-1][0] - rows[0][0], rows[-1][1] - rows[0][1]
print(f"whole pull: {s:.2f} simulated s in {w:.2f} wall s = {s / w:.2f} x real time; "
      f"slowest half second {min(r[2] for r in rows[1:]):.2f} x; "
      f"frames/s {min(r[4] for r in rows[1:]):.1f} to {max(r[4] for r in rows[1:]):.1f}")
PY
