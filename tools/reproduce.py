#!/usr/bin/env python3
"""Regenerates docs/reproduction.md: wetcloth against the thesis' evaluation (figs. 4.2-4.6,
table 4.2).

Runs every scene of scenes/ with the release build, measures what the thesis shows (lifted
area, tent height, grab force, bubble pressure and volume, stretch), renders one picture per
figure into docs/images/reproduction/, runs `wetcloth bench` for table 4.2, and writes the
document with a verdict per figure. Needs Python 3.8+, the Rust toolchain, Mesa's software
Vulkan (or a GPU) for the pictures, and ImageMagick's `convert` to shrink them (optional).

    python3 tools/reproduce.py            # everything (about a quarter of an hour on 2 cores)
    python3 tools/reproduce.py --quick    # shorter bench windows
"""

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "out" / "reproduction"
IMAGES = ROOT / "docs" / "images" / "reproduction"
DOC = ROOT / "docs" / "reproduction.md"
BIN = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "wetcloth"

# Lifted: more than this above the resting height of the particle centres (m).
LIFT = 0.001
# Disturbed: more than this above the resting height (m), to see how far wrinkles reach.
DISTURBED = 0.0002


def sh(*args, **kw):
    print("+", " ".join(str(a) for a in args), flush=True)
    return subprocess.run([str(a) for a in args], check=True, **kw)


def read_metrics(run):
    with open(run / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    return [{k: float(v) for k, v in r.items()} for r in rows]


def read_obj(path):
    verts = []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append(tuple(float(t) for t in line.split()[1:4]))
    return verts


def run_info(run):
    with open(run / "run.json") as f:
        return json.load(f)


def frame_at(run, info, t):
    """Path of the frame closest to time t."""
    k = min(int(round(t * info["frame_rate"])), info["frames"] - 1)
    return run / "frames" / f"frame_{k:04d}.obj"


def shape_measures(run, info, t, pinches):
    """Lifted area (cm^2), tent height (mm), disturbed radius (cm), and the lifted extent
    along the grid axes and the diagonals from the first pinch (cm)."""
    nx, nz = info["resolution"]
    sx, sz = info["size"]
    r = info["particle_radius"]
    v = read_obj(frame_at(run, info, t))
    cell = (sx / (nx - 1)) * (sz / (nz - 1))
    heights = [p[1] - r for p in v]
    lifted = sum(1 for h in heights if h > LIFT)
    area = lifted * sx * sz / (nx * nz)
    # Distances from the pinches, in the cloth's rest coordinates (grid units -> m).
    dx, dz = sx / (nx - 1), sz / (nz - 1)
    radius = 0.0
    axis, diag = 0.0, 0.0
    ci, cj = pinches[0]
    for k, h in enumerate(heights):
        if h <= DISTURBED:
            continue
        i, j = k % nx, k // nx
        d = min(math.hypot((i - a) * dx, (j - b) * dz) for a, b in pinches)
        radius = max(radius, d)
        di, dj = i - ci, j - cj
        if h > LIFT:
            if di == 0 or dj == 0:
                axis = max(axis, math.hypot(di * dx, dj * dz))
            if abs(di) == abs(dj):
                diag = max(diag, math.hypot(di * dx, dj * dz))
    return {
        "lifted_cm2": area * 1e4,
        "lifted_fraction": lifted / (nx * nz),
        "height_mm": max(heights) * 1e3,
        "disturbed_cm": radius * 1e2,
        "axis_cm": axis * 1e2,
        "diag_cm": diag * 1e2,
        "cell_cm2": cell * 1e4,
    }


def fold_measures(run, info, t, pinches, hand=1, radii=(4, 5, 6, 8)):
    """The fold pattern around the first of `pinches`: for circles of `radii` grid cells around it (in
    rest coordinates), the directions (degrees from +x, the weave) of the ridges, local maxima
    of the height along the circle that stand out from their neighbourhood (+-22.5 degrees) by
    more than 5 % of the circle's mean height; and the largest stretch of the weave (structural)
    and of the diagonal (shear) springs away from the hands (both ends more than `hand` + 1
    cells from every pinch: the fingertip's edge concentrates the pull)."""
    nx, nz = info["resolution"]
    sx, sz = info["size"]
    r = info["particle_radius"]
    v = read_obj(frame_at(run, info, t))
    h = [p[1] - r for p in v]
    ci, cj = pinches[0]

    def height(x, z):
        x = min(max(x, 0.0), nx - 1.001)
        z = min(max(z, 0.0), nz - 1.001)
        i, j = int(x), int(z)
        fx, fz = x - i, z - j
        g = lambda a, b: h[b * nx + a]
        return (g(i, j) * (1 - fx) * (1 - fz) + g(i + 1, j) * fx * (1 - fz)
                + g(i, j + 1) * (1 - fx) * fz + g(i + 1, j + 1) * fx * fz)

    n = 144
    ridges = {}
    for rad in radii:
        vals = [height(ci + rad * math.cos(2 * math.pi * a / n), cj + rad * math.sin(2 * math.pi * a / n))
                for a in range(n)]
        mean = sum(vals) / n
        ridges[rad] = {
            "mean_mm": mean * 1e3,
            "amplitude_mm": (max(vals) - min(vals)) * 1e3,
            "angles": [round(a * 360 / n) for a in range(n)
                       if vals[a] > vals[a - 1] and vals[a] >= vals[(a + 1) % n]
                       and vals[a] - min(vals[(a + b) % n] for b in range(-9, 10))
                       > 0.05 * max(mean, 1e-12)],
        }
    dx, dz = sx / (nx - 1), sz / (nz - 1)
    weave = shear = 0.0
    for j in range(nz):
        for i in range(nx):
            for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
                a, b = i + di, j + dj
                if not (0 <= a < nx and 0 <= b < nz):
                    continue
                if any(min(max(abs(i - pi), abs(j - pj)), max(abs(a - pi), abs(b - pj))) <= hand + 1
                       for pi, pj in pinches):
                    continue
                rest = math.hypot(di * dx, dj * dz)
                e = math.dist(v[j * nx + i], v[b * nx + a]) / rest - 1.0
                if di == 0 or dj == 0:
                    weave = max(weave, e)
                else:
                    shear = max(shear, e)
    return {"ridges": ridges, "weave_pct": weave * 100, "shear_pct": shear * 100}


def render(run, name, t, camera, size="480x270", extra=()):
    info = run_info(run)
    k = min(int(round(t * info["frame_rate"])), info["frames"] - 1)
    out = OUT / "render" / name
    sh(BIN, "render", run, "--out", out, "--frames", str(k), "--size", size,
       "--camera", camera, "--no-video", "--quiet", *extra)
    src = out / f"frame_{k:04d}.png"
    IMAGES.mkdir(parents=True, exist_ok=True)
    dst = IMAGES / f"{name}.png"
    if shutil.which("convert"):
        # Quantise to a palette: smooth shading compresses to a fraction of the size.
        sh("convert", src, "+dither", "-colors", "128", "-strip", f"PNG8:{dst}")
    else:
        shutil.copy(src, dst)
    return dst.relative_to(DOC.parent)


def read_pockets(run):
    """pockets.csv as {frame: [row, ...]} with numeric fields."""
    out = {}
    with open(run / "pockets.csv") as f:
        for r in csv.DictReader(f):
            row = {k: float(v) for k, v in r.items()}
            out.setdefault(int(row["frame"]), []).append(row)
    return out


def render_supports(flag):
    """Whether `wetcloth render` knows `flag` (so the script runs on older builds too)."""
    h = subprocess.run([str(BIN), "render", "--help"], capture_output=True, text=True).stdout
    return flag in h


def run_scene(name):
    run = OUT / name
    sh(BIN, "run", ROOT / "scenes" / f"{name}.toml", "--out", run, "--quiet")
    return run


def fmt(x, digits=3):
    """A number for the tables: integers from 1000 up, `digits` significant digits below."""
    if x == 0:
        return "0"
    if abs(x) >= 1000:
        return f"{x:.0f}"
    return f"{x:.{digits}g}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short bench windows")
    args = ap.parse_args()

    os.environ.setdefault("XDG_RUNTIME_DIR", "/tmp")
    sh("cargo", "build", "--release", "-p", "wetcloth-cli", cwd=ROOT)
    OUT.mkdir(parents=True, exist_ok=True)

    names = ["settle", "pinch-center", "pinch-two", "air-0", "air-400", "pinch-dry", "peel-leak",
             "pinch-fine", "pinch-fine-two"]
    runs = {n: run_scene(n) for n in names}
    m = {n: read_metrics(runs[n]) for n in names}
    info = {n: run_info(runs[n]) for n in names}
    last = {n: m[n][-1] for n in names}

    # ---- Fig. 4.2: sticking over time --------------------------------------------------------
    settle = m["settle"]
    t_stuck = next((r["time"] for r in settle if r["contact_fraction"] >= 0.999), None)
    # The same scene with the air force off, for the sliding comparison.
    dry_settle = (ROOT / "scenes" / "settle.toml").read_text().replace(
        "[air]\nenabled = true", "[air]\nenabled = false").replace(
        'name = "settle"', 'name = "settle-dry"')
    dry_path = OUT / "settle-dry.toml"
    dry_path.write_text(dry_settle)
    sh(BIN, "run", dry_path, "--out", OUT / "settle-dry", "--quiet")

    def mean_x(run, k):
        v = read_obj(run / "frames" / f"frame_{k:04d}.obj")
        return sum(p[0] for p in v) / len(v)

    kl = info["settle"]["frames"] - 1
    slide_wet = mean_x(runs["settle"], kl) - mean_x(runs["settle"], 0)
    slide_dry = mean_x(OUT / "settle-dry", kl) - mean_x(OUT / "settle-dry", 0)
    img_settle = render(runs["settle"], "fig-4-2-settle", 0.05, "20,25,0.55")

    # ---- Figs. 4.3-4.6: pinches ----------------------------------------------------------
    lift_end = 1.25
    shapes = {
        "pinch-center": shape_measures(runs["pinch-center"], info["pinch-center"], lift_end, [(25, 25)]),
        "pinch-two": shape_measures(runs["pinch-two"], info["pinch-two"], lift_end, [(17, 25), (33, 25)]),
        "air-0": shape_measures(runs["air-0"], info["air-0"], lift_end, [(25, 25)]),
        "air-400": shape_measures(runs["air-400"], info["air-400"], 1.75, [(25, 25)]),
        "pinch-dry": shape_measures(runs["pinch-dry"], info["pinch-dry"], lift_end, [(25, 25)]),
        "pinch-fine": shape_measures(runs["pinch-fine"], info["pinch-fine"], lift_end, [(50, 50)]),
        "pinch-fine-two": shape_measures(runs["pinch-fine-two"], info["pinch-fine-two"], lift_end,
                                         [(33, 50), (66, 50)]),
    }
    folds = {
        "pinch-fine": fold_measures(runs["pinch-fine"], info["pinch-fine"], lift_end, [(50, 50)]),
        "pinch-fine-two": fold_measures(runs["pinch-fine-two"], info["pinch-fine-two"], lift_end,
                                        [(33, 50), (66, 50)]),
    }
    # The fine pinch with air coming in through the wet weave (the pockets model's Darcy
    # permeability): does it let the cloth fold the way the thesis' photograph does?
    perm = (ROOT / "scenes" / "pinch-fine.toml").read_text().replace(
        'name = "pinch-fine"', 'name = "pinch-fine-permeable"').replace(
        "duration = 2.5", "duration = 1.25").replace(
        "trapped_air = 0.0", 'trapped_air = 0.0\nmodel = "pockets"\npermeability = 1e-8')
    perm_path = OUT / "pinch-fine-permeable.toml"
    perm_path.write_text(perm)
    sh(BIN, "run", perm_path, "--out", OUT / "pinch-fine-permeable", "--quiet")
    runs["pinch-fine-permeable"] = OUT / "pinch-fine-permeable"
    m["pinch-fine-permeable"] = read_metrics(runs["pinch-fine-permeable"])
    info["pinch-fine-permeable"] = run_info(runs["pinch-fine-permeable"])
    last["pinch-fine-permeable"] = m["pinch-fine-permeable"][-1]
    shapes["pinch-fine-permeable"] = shape_measures(
        runs["pinch-fine-permeable"], info["pinch-fine-permeable"], lift_end, [(50, 50)])
    folds["pinch-fine-permeable"] = fold_measures(
        runs["pinch-fine-permeable"], info["pinch-fine-permeable"], lift_end, [(50, 50)])
    # Framed on the pinch (the tent and the hand), a little above the table.
    close = "yaw=35;pitch=22;distance=0.08;target=0,0.004,0"
    img = {
        "pinch-center": render(runs["pinch-center"], "fig-4-3-pinch-center", lift_end, close),
        "pinch-two": render(runs["pinch-two"], "fig-4-4-pinch-two", lift_end,
                            "yaw=20;pitch=35;distance=0.2;target=0,0.002,0.01"),
        "air-0": render(runs["air-0"], "fig-4-5-air-0", lift_end, close),
        "air-400": render(runs["air-400"], "fig-4-6-air-400", 1.75, "35,25,0.5"),
        "pinch-dry": render(runs["pinch-dry"], "baseline-pinch-dry", lift_end, "35,25,0.5"),
        # Framed on the pinch, looking along a diagonal so that the ridges along the weave
        # stand out against the sky on either side of the tent.
        "pinch-fine": render(runs["pinch-fine"], "fig-4-3-pinch-fine", lift_end,
                             "yaw=45;pitch=12;distance=0.08;target=0,0.004,0",
                             extra=("--no-grabs",)),
        "pinch-fine-top": render(runs["pinch-fine"], "fig-4-3-pinch-fine-above", lift_end,
                                 "yaw=20;pitch=30;distance=0.09;target=0,0.003,0",
                                 extra=("--no-grabs",)),
        "pinch-fine-two": render(runs["pinch-fine-two"], "fig-4-4-pinch-fine-two", lift_end,
                                 "yaw=20;pitch=22;distance=0.17;target=0,0.003,0",
                                 extra=("--no-grabs",)),
        "pinch-fine-permeable": render(runs["pinch-fine-permeable"], "fig-4-3-pinch-fine-permeable",
                                       lift_end, "yaw=30;pitch=35;distance=0.35;target=0,0.004,0",
                                       extra=("--no-grabs",)),
        "peel-leak": render(runs["peel-leak"], "beyond-peel-leak", 1.75,
                            "yaw=-120 pitch=30 distance=0.22 target=-0.12,0,-0.12"),
    }

    def peak(n, key):
        return max(r[key] for r in m[n])

    # ---- Table 4.2 ------------------------------------------------------------------------
    bench_json = OUT / "bench.json"
    sh(BIN, "bench", "--threads", "1,2", "--seconds", "0.5" if args.quick else "3",
       "--json", bench_json, "--quiet")
    bench = json.loads(bench_json.read_text())

    # ---- Beyond the thesis: air pockets ---------------------------------------------------
    pk_names = ["pockets-corner", "pockets-middle", "pockets-bubbles", "pockets-bubbles-dry",
                "pockets-merge", "pockets-breathing"]
    for n in pk_names:
        runs[n] = run_scene(n)
        m[n] = read_metrics(runs[n])
        info[n] = run_info(runs[n])
    pk = {n: read_pockets(runs[n]) for n in pk_names}
    # The corner and middle lifts with the thesis' single bubble, for comparison.
    for n in ["pockets-corner", "pockets-middle"]:
        text = (ROOT / "scenes" / f"{n}.toml").read_text()
        text = text.replace('model = "pockets"', 'model = "thesis"').replace(
            f'name = "{n}"', f'name = "{n}-thesis"')
        path = OUT / f"{n}-thesis.toml"
        path.write_text(text)
        sh(BIN, "run", path, "--out", OUT / f"{n}-thesis", "--quiet")
        m[f"{n}-thesis"] = read_metrics(OUT / f"{n}-thesis")
    tint = ("--pockets",) if render_supports("--pockets") else ()
    img["pockets-bubbles"] = render(runs["pockets-bubbles"], "beyond-pockets-bubbles", 1.0,
                                    "yaw=-60 pitch=45 distance=0.45 target=0,0,0", extra=tint)
    img["pockets-middle"] = render(runs["pockets-middle"], "beyond-pockets-middle", 1.5,
                                   "yaw=35;pitch=35;distance=0.1;target=0,0.002,0.01",
                                   extra=tint)
    img["pockets-corner"] = render(runs["pockets-corner"], "beyond-pockets-corner", 1.5,
                                   "yaw=-120 pitch=30 distance=0.22 target=-0.12,0,-0.12",
                                   extra=tint)
    # Wet cloth on meshes and moving colliders, with the pockets measuring against them.
    for n in ["head-drape", "ball-pull", "tilted-lift"]:
        runs[n] = run_scene(n)
        m[n] = read_metrics(runs[n])
        info[n] = run_info(runs[n])
    img["head-drape"] = render(runs["head-drape"], "beyond-head-drape", 1.5,
                               "yaw=-30 pitch=20 distance=0.6 target=0,0.12,0")
    # Cloths of any shape: the shipped mesh scenes (meshes by tools/make_cloth_meshes.py).
    mesh_scenes = ["towel-pinned", "towel-lift-corner", "towel-lift-middle", "tablecloth-round"]
    for n in mesh_scenes:
        runs[n] = run_scene(n)
        m[n] = read_metrics(runs[n])
        info[n] = run_info(runs[n])
    grabs = {}
    for n in mesh_scenes:
        with open(runs[n] / "grabs.csv") as f:
            grabs[n] = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
    img["towel-pinned"] = render(runs["towel-pinned"], "beyond-towel-pinned", 3.0,
                                 "yaw=-30 pitch=10 distance=2.0 target=0,0.95,0")
    img["towel-lift-middle"] = render(runs["towel-lift-middle"], "beyond-towel-lift-middle", 2.0,
                                      "yaw=-35 pitch=25 distance=0.45 target=0,0.005,0",
                                      extra=tint)
    img["towel-lift-corner"] = render(runs["towel-lift-corner"], "beyond-towel-lift-corner", 2.0,
                                      "yaw=-35 pitch=30 distance=1.0 target=-0.1,0,-0.15",
                                      extra=tint)
    img["tablecloth-round"] = render(runs["tablecloth-round"], "beyond-tablecloth-round", 2.5,
                                     "yaw=40 pitch=15 distance=2.4 target=0.2,0.5,0")
    # Speed: the pockets model against the thesis' on the bench workload, alternating runs.
    pk_bench = {"thesis": [], "pockets": []}
    for r in range(3):
        for model in ["thesis", "pockets"]:
            path = OUT / f"bench-{model}-{r}.json"
            sh(BIN, "bench", "--sizes", "50", "--threads", "1,2", "--seconds",
               "0.5" if args.quick else "2", "--air-model", model, "--json", path, "--quiet")
            pk_bench[model].append(json.loads(path.read_text()))

    # ---- The document ---------------------------------------------------------------------
    L = []
    w = L.append
    w("# wetcloth against the thesis")
    w("")
    w("This page is generated by `python3 tools/reproduce.py`; do not edit it by hand. It runs "
      "every scene in `scenes/`, measures what the thesis' figures show, renders one picture "
      "per figure, and runs `wetcloth bench` for table 4.2. The thesis' figures are "
      "photographs and screenshots without numbers, so each verdict compares the behaviour "
      "the thesis describes with quantities measured here. Lifted means more than "
      f"{LIFT * 1e3:g} mm above the resting height of the particles; disturbed, more than "
      f"{DISTURBED * 1e3:g} mm.")
    w("")
    w("All scenes use the thesis' cloth (30 cm square, 50 x 50 particles, 20 g). Its spring "
      "constants are not given: `settle` uses 500 N/m (structural) and 125 N/m (shear) at the "
      "thesis' step of 1/12000 s, the pinch scenes a stiffer 5000 and 1250 N/m at 1/36000 s "
      "(the explicit step must shrink with the stiffness); `scenes/README.md` explains why. "
      "The fine pinches (`pinch-fine`, `pinch-fine-two`) put the same cloth on 100 x 100 "
      "particles at 200 000 and 10 000 N/m, with the implicit integrator at 1/600 s.")
    w("")

    s = last["settle"]
    w("## Fig. 4.2: the cloth sticks over time")
    w("")
    w(f"Scene `scenes/settle.toml`: the cloth starts 2 cm above a table tilted by 10 degrees "
      f"(friction 0.15 < tan 10 deg), with no air under it.")
    w("")
    w(f"![settle]({img_settle})")
    w("")
    w("| quantity | wet (air force on) | dry (air force off) |")
    w("|---|---|---|")
    w(f"| all particles in contact after | {fmt(t_stuck or float('nan'))} s | - |")
    w(f"| slide down the slope in {fmt(s['time'])} s | {fmt(slide_wet * 1e3)} mm | "
      f"{fmt(slide_dry * 1e3)} mm |")
    w("")
    ok = t_stuck is not None and abs(slide_wet) < 0.01 * abs(slide_dry)
    w(f"**Verdict: {'reproduced' if ok else 'not reproduced'}.** The pressure difference "
      f"drives the cloth onto the table within {fmt((t_stuck or 0) * 1e3)} ms and then holds it: "
      f"the normal force is the atmosphere's, so friction holds the cloth on a slope it "
      f"slides down when dry. The thesis shows the cloth sticking progressively over its "
      f"frames; here, with no trapped air, the vacuum under the cloth makes that fast (the "
      f"atmosphere accelerates a 20 g cloth at tens of thousands of g).")
    w("")

    def shape_rows(names):
        w("| quantity | " + " | ".join(f"`{n}`" for n in names) + " |")
        w("|---|" + "---|" * len(names))
        rows = [
            ("trapped air (cm^3)", lambda n: fmt(m[n][0]["trapped_air"] * 1e6 if "trapped_air" in m[n][0] else 0)),
            ("lifted area (cm^2)", lambda n: fmt(shapes[n]["lifted_cm2"])),
            ("tent height (mm)", lambda n: fmt(shapes[n]["height_mm"])),
            ("disturbed radius (cm)", lambda n: fmt(shapes[n]["disturbed_cm"])),
            ("lifted reach along the weave / diagonal (cm)",
             lambda n: f"{fmt(shapes[n]['axis_cm'])} / {fmt(shapes[n]['diag_cm'])}"),
            ("peak grab force (N)", lambda n: fmt(peak(n, "grab_force"))),
            ("bubble pressure at the end (kPa)", lambda n: fmt(last[n]["air_pressure"] / 1e3)),
            ("bubble volume at the end (cm^3)", lambda n: fmt(last[n]["air_volume"] * 1e6)),
            ("largest stretch (%)", lambda n: fmt(peak(n, "max_stretch") * 100)),
            ("contact fraction at the end", lambda n: fmt(last[n]["contact_fraction"])),
        ]
        for label, f in rows:
            w(f"| {label} | " + " | ".join(f(n) for n in names) + " |")
        w("")

    pc, pd = shapes["pinch-center"], shapes["pinch-dry"]
    ratio = peak("pinch-center", "grab_force") / max(peak("pinch-dry", "grab_force"), 1e-30)
    w("## Fig. 4.3: picked up at one point")
    w("")
    w("Scene `scenes/pinch-center.toml` (no trapped air, centre lifted 1.2 cm over 1 s); "
      "baseline `scenes/pinch-dry.toml` (the same with the air force off). Pictures at the end "
      "of the lift.")
    w("")
    w(f"![pinch, wet]({img['pinch-center']}) ![pinch, dry]({img['pinch-dry']})")
    w("")
    shape_rows(["pinch-center", "pinch-dry"])
    small = pc["lifted_cm2"] < 0.1 * max(pd["lifted_cm2"], 1e-9)
    w(f"**Verdict: partly reproduced.** As in the thesis, only a small region around the "
      f"pinch leaves the table ({fmt(pc['lifted_cm2'])} cm^2 against {fmt(pd['lifted_cm2'])} "
      f"cm^2 dry{'' if small else '; not much smaller than dry'}) while the rest stays pressed "
      f"flat, and the hand needs {fmt(ratio)} times the force of the dry lift. But the "
      f"cross-shaped folds of its photograph are not resolved: the lifted region is "
      f"{round(pc['lifted_cm2'] / pc['cell_cm2'])} particles around the pinch, reaching "
      f"{fmt(pc['axis_cm'])} cm along the weave and {fmt(pc['diag_cm'])} cm along the "
      f"diagonals, one grid cell either way, too few particles to fold; the fine cloth below "
      f"resolves them.")
    w("")

    def ridge_text(f, rad):
        r = f["ridges"][rad]
        return (", ".join(f"{a}" for a in r["angles"]) or "none") + f" ({fmt(r['amplitude_mm'])} mm)"

    def fine_rows(names):
        w("| quantity | " + " | ".join(f"`{n}`" for n in names) + " |")
        w("|---|" + "---|" * len(names))
        rows = [
            ("particles, spacing (mm)", lambda n: f"{info[n]['resolution'][0]} x {info[n]['resolution'][1]}, "
             f"{fmt(info[n]['size'][0] / (info[n]['resolution'][0] - 1) * 1e3)}"),
            ("lifted area (cm^2), particles", lambda n: f"{fmt(shapes[n]['lifted_cm2'])}, "
             f"{round(shapes[n]['lifted_cm2'] / shapes[n]['cell_cm2'])}"),
            ("tent height (mm)", lambda n: fmt(shapes[n]["height_mm"])),
            ("lifted reach along the weave / diagonal (cm)",
             lambda n: f"{fmt(shapes[n]['axis_cm'])} / {fmt(shapes[n]['diag_cm'])}"),
            ("peak grab force (N)", lambda n: fmt(peak(n, "grab_force"))),
            ("largest stretch of the weave, anywhere (%)", lambda n: fmt(peak(n, "max_stretch") * 100)),
            ("largest stretch away from the hands, weave / shear springs (%)",
             lambda n: f"{fmt(folds[n]['weave_pct'])} / {fmt(folds[n]['shear_pct'])}"
             if n in folds else "-"),
        ] + [
            (f"ridges {rad} cells ({fmt(rad * spacing * 1e3)} mm) from the (first) pinch: "
             f"directions (deg from the weave), height range",
             lambda n, rad=rad: ridge_text(folds[n], rad) if n in folds else "-")
            for rad in (4, 6, 8)
        ]
        for label, f in rows:
            w(f"| {label} | " + " | ".join(f(n) for n in names) + " |")
        w("")

    def cross(f):
        """Four ridges along the weave (within 10 degrees of 0, 90, 180, 270) on the outer
        circles: the cross."""
        def on_weave(a):
            return min(abs(a - b) for b in (0, 90, 180, 270, 360)) <= 10
        return all(len(f["ridges"][rad]["angles"]) == 4 and all(on_weave(a) for a in f["ridges"][rad]["angles"])
                   for rad in (6, 8))

    pf, ff = shapes["pinch-fine"], folds["pinch-fine"]
    spacing = info["pinch-fine"]["size"][0] / (info["pinch-fine"]["resolution"][0] - 1)
    w("### On a fine, stiff cloth")
    w("")
    w("Scene `scenes/pinch-fine.toml`: the same satin (30 cm, 20 g) at 100 x 100 particles, "
      "stiff along the threads (200 000 N/m) and twenty times softer in shear (10 000 N/m), as "
      "woven cloth is; lifted 1.2 cm over 1 s by a fingertip (3 x 3 particles, 9 mm) with no "
      "trapped air. The explicit integrator would need a step of about 1/330 000 s on this "
      "cloth; it runs with the implicit one at 1/600 s. Pictures at the end of the lift, "
      "framed on the pinch: along a diagonal, then from above at 20 degrees.")
    w("")
    w(f"![fine pinch, along the diagonal]({img['pinch-fine']}) "
      f"![fine pinch, from above]({img['pinch-fine-top']})")
    w("")
    fine_rows(["pinch-center", "pinch-fine"])
    okf = cross(ff) and pf["lifted_cm2"] / pf["cell_cm2"] > 50 and ff["weave_pct"] < 10
    w(f"**Verdict: {'reproduced' if okf else 'not reproduced'}.** On the fine cloth the lifted "
      f"region is a tent of {round(pf['lifted_cm2'] / pf['cell_cm2'])} particles "
      f"({fmt(pf['lifted_cm2'])} cm^2), pressed flat around it by the atmosphere as before, and "
      f"it is {'cross-shaped' if cross(ff) else 'not cross-shaped'}: on circles 6 and 8 cells "
      f"({fmt(6 * spacing * 100)} and {fmt(8 * spacing * 100)} cm) around the pinch the cloth "
      f"rises in ridges at {', '.join(str(a) for a in ff['ridges'][6]['angles'])} degrees from "
      f"the weave, {fmt(ff['ridges'][6]['amplitude_mm'])} and {fmt(ff['ridges'][8]['amplitude_mm'])} "
      f"mm above the valleys between them. The threads carry the pull straight out from the "
      f"fingertip and the cloth between them gives way in shear, as the thesis explains its "
      f"photograph. Away from the fingertip the threads stretch at most "
      f"{fmt(ff['weave_pct'])} % (the shear springs, which measure the weave's change of angle, "
      f"{fmt(ff['shear_pct'])} %); at the fingertip's edge, where the whole pull of "
      f"{fmt(peak('pinch-fine', 'grab_force'))} N enters the cloth, "
      f"{fmt(peak('pinch-fine', 'max_stretch') * 100)} % (the coarse cloth: "
      f"{fmt(peak('pinch-center', 'max_stretch') * 100)} %).")
    w("")
    pp, fp = shapes["pinch-fine-permeable"], folds["pinch-fine-permeable"]
    mp = m["pinch-fine-permeable"]
    opened = next((r["time"] for a, r in zip(mp, mp[1:]) if a["pocket_count"] > 0 and r["pocket_count"] == 0), None)
    w(f"*Air through the wet weave.* The same lift with the pockets model and a permeability of "
      f"1e-8 m/(s Pa) (`[air] model = \"pockets\"`, `permeability = 1e-8`): the vacuum under "
      f"the tent fills through the weave, the pocket grows with the lifted cloth"
      + (f" until it reaches the border at {fmt(opened)} s and opens to the room" if opened else "")
      + f"; from then on only the water film holds the cloth, which comes up like a dry one: "
      f"{fmt(pp['lifted_cm2'])} cm^2 lifted at the end of the lift (hand force at most "
      f"{fmt(peak('pinch-fine-permeable', 'grab_force'))} N), folds radiating across the whole "
      f"cloth and none near the fingertip (ridges 6 cells out: {ridge_text(fp, 6)}). Air "
      f"through the weave is not what folds the cloth around the pinch in the thesis' "
      f"photograph; the weave's stiffness against its shear is.")
    w("")
    w(f"![fine pinch, permeable]({img['pinch-fine-permeable']})")
    w("")

    p2 = shapes["pinch-two"]
    w("## Fig. 4.4: picked up at two points")
    w("")
    w("Scene `scenes/pinch-two.toml`: two points 10 cm apart, each lifted 1.2 cm.")
    w("")
    w(f"![two pinches]({img['pinch-two']})")
    w("")
    shape_rows(["pinch-two", "pinch-center"])
    f2 = peak("pinch-two", "grab_force") / max(peak("pinch-center", "grab_force"), 1e-30)
    w(f"**Verdict: reproduced, as far as the single pinch is.** Two separate small lifted "
      f"regions ({fmt(p2['lifted_cm2'])} cm^2 in all, {fmt(p2['lifted_cm2'] / max(pc['lifted_cm2'], 1e-9))} "
      f"times one pinch's), and the hands together need {fmt(f2)} times the force of one: the "
      f"atmosphere presses each lifted region independently. The ridge of folds between the "
      f"points in the thesis' photograph does not form at this resolution: with the cloth "
      f"between them held flat by 101 kPa, nothing connects the two cones (nor on the fine "
      f"cloth below).")
    w("")

    p2f, f2f = shapes["pinch-fine-two"], folds["pinch-fine-two"]
    run2 = runs["pinch-fine-two"]
    v2 = read_obj(frame_at(run2, info["pinch-fine-two"], lift_end))
    r2 = info["pinch-fine-two"]["particle_radius"]
    line = [v2[50 * 100 + i][1] - r2 for i in range(33, 67)]
    mid = min(line)
    w("### On a fine, stiff cloth")
    w("")
    w("Scene `scenes/pinch-fine-two.toml`: `pinch-fine`'s cloth lifted by two fingertips 10 cm "
      "apart.")
    w("")
    w(f"![two fine pinches]({img['pinch-fine-two']})")
    w("")
    fine_rows(["pinch-fine-two", "pinch-fine"])
    ok2 = cross(f2f)
    w(f"**Verdict: {'partly reproduced' if ok2 else 'not reproduced'}.** Each fingertip raises "
      f"a tent {'with the same cross of ridges along the weave' if ok2 else 'without a clear cross'} "
      f"({fmt(p2f['lifted_cm2'])} cm^2 in all, {fmt(p2f['lifted_cm2'] / max(pf['lifted_cm2'], 1e-9))} "
      f"times one pinch's, for {fmt(peak('pinch-fine-two', 'grab_force') / max(peak('pinch-fine', 'grab_force'), 1e-30))} "
      f"times the force). The ridges pointing at each other along the line between the pinches "
      f"{'do not join' if mid < LIFT else 'join'}: the cloth halfway between them lies "
      f"{fmt(mid * 1e3)} mm above the table, held there by the vacuum, where the thesis' "
      f"photograph shows one fold running from pinch to pinch.")
    w("")

    a0, a4 = shapes["air-0"], shapes["air-400"]
    w("## Fig. 4.5: no trapped air")
    w("")
    w("Scene `scenes/air-0.toml` (the single pinch with v0 = 0 cm^3).")
    w("")
    w(f"![no air]({img['air-0']})")
    w("")
    shape_rows(["air-0"])
    ok45 = last["air-0"]["air_volume"] < 5e-6 and peak("air-0", "max_stretch") > 0.3
    w(f"**Verdict: {'reproduced' if ok45 else 'not reproduced'}.** No gap opens between cloth "
      f"and table away from the pinch (the whole bubble is {fmt(last['air-0']['air_volume'] * 1e6)} "
      f"cm^3, all of it under the lifted cone; {fmt(last['air-0']['contact_fraction'] * 100)} % of "
      f"the particles touch the table), the disturbance stays within "
      f"{fmt(a0['disturbed_cm'])} cm of the pulled point, and the springs around it stretch by "
      f"{fmt(peak('air-0', 'max_stretch') * 100)} %: the over-stretch the thesis reports for its "
      f"mass-spring cloth under the pressure force. `strain_limit` (Provot) caps it when wanted.")
    w("")

    w("## Fig. 4.6: 400 cm^3 of trapped air")
    w("")
    w("Scene `scenes/air-400.toml`: the cloth starts at the height that holds 400 cm^3 at "
      "atmospheric pressure, and its centre is lifted 5 cm over 1.5 s.")
    w("")
    w(f"![400 cm^3]({img['air-400']})")
    w("")
    shape_rows(["air-400", "air-0"])
    ok46 = a4["lifted_cm2"] > 10 * a0["lifted_cm2"] and a4["disturbed_cm"] > a0["disturbed_cm"]
    w(f"**Verdict: {'reproduced' if ok46 else 'not reproduced'}.** Lifting makes a tent "
      f"{fmt(a4['height_mm'])} mm high over {fmt(a4['lifted_cm2'])} cm^2: the air flows from "
      f"under the rest of the cloth, which sinks onto the table, into the tent (the bubble "
      f"keeps {fmt(last['air-400']['air_volume'] * 1e6)} cm^3 at "
      f"{fmt(last['air-400']['air_pressure'] / 1e3)} kPa), and with the weaker pressing the "
      f"disturbance reaches {fmt(a4['disturbed_cm'])} cm from the pulled point against "
      f"{fmt(a0['disturbed_cm'])} cm without air, as the thesis observes for its wrinkles.")
    w("")

    pl = last["peel-leak"]
    w("## Beyond the thesis: air leaking in under a peeled corner")
    w("")
    w("Scene `scenes/peel-leak.toml`: a corner peeled up 3 cm while air flows in where the "
      "border is lifted (`[air] leak_conductance`), the thesis' future work. Sealed, the same "
      "peel tears this cloth; with the leak the bubble holds "
      f"{fmt(pl['trapped_air'] * 1e6)} cm^3 of air at the end, at "
      f"{fmt(pl['air_pressure'] / 1e3)} kPa, and the hand's force peaks at "
      f"{fmt(peak('peel-leak', 'grab_force'))} N.")
    w("")
    w(f"![peel with a leak]({img['peel-leak']})")
    w("")

    w("## Beyond the thesis: air pockets")
    w("")
    w("With `[air] model = \"pockets\"` the air under a wet cloth is a set of sealed pockets, "
      "each with its own air and Boyle pressure; a pocket that reaches the cloth's border is "
      "open to the room (`docs/scene-format.md`, `crates/wetcloth/src/air/pockets.rs`). "
      "Measured from each scene's `metrics.csv` and `pockets.csv`:")
    w("")
    pc, pm = peak("pockets-corner", "grab_force"), peak("pockets-middle", "grab_force")
    tc, tm = peak("pockets-corner-thesis", "grab_force"), peak("pockets-middle-thesis", "grab_force")
    w("| scene | what is measured | pockets model | thesis model |")
    w("|---|---|---|---|")
    w(f"| `pockets-corner` | peak hand force lifting a corner 1.2 cm | {fmt(pc)} N | {fmt(tc)} N |")
    w(f"| `pockets-middle` | peak hand force lifting the middle 1.2 cm | {fmt(pm)} N | {fmt(tm)} N |")
    w(f"| | middle / corner | {fmt(pm / pc)}x | {fmt(tm / tc)}x |")
    bub = pk["pockets-bubbles"]
    seeds = sorted(p["amount"] for p in bub[0])
    drift = max(abs(sum(p["amount"] for p in rows) - sum(seeds)) / sum(seeds)
                for rows in bub.values())
    boyle = max(abs(p["pressure"] * p["volume"] - 101325.0 * p["amount"]) / (101325.0 * p["amount"])
                for rows in bub.values() for p in rows if p["amount"] > 0 and p["frame"] > 0)
    counts = sorted({len(rows) for rows in bub.values()})
    w(f"| `pockets-bubbles` | three seeded bubbles ({', '.join(fmt(a * 1e6) for a in seeds)} cm^3) under a wet cloth pressed beside them | pockets per frame {counts[0]}-{counts[-1]}, total air drift {drift:.1e}, largest P V / (P_a N) - 1 {boyle:.1e} | |")
    dry = m["pockets-bubbles-dry"]
    w(f"| `pockets-bubbles-dry` | the same under a dry cloth | pockets after the first frame: {int(max(r['pocket_count'] for r in dry[1:]))}, air trapped {fmt(max(r['trapped_air'] for r in dry[1:]) * 1e6)} cm^3 | |")
    mg = m["pockets-merge"]
    before = mg[0]["trapped_air"]
    after = mg[-1]["trapped_air"]
    biggest = max(p["amount"] for p in pk["pockets-merge"][max(pk["pockets-merge"])])
    w(f"| `pockets-merge` | two 20 cm^3 pockets joined by lifting the seam | largest pocket at the end {fmt(biggest * 1e6)} cm^3; sealed air {fmt(before * 1e6)} -> {fmt(after * 1e6)} cm^3 | |")
    br = m["pockets-breathing"]
    amounts = [r["trapped_air"] * 1e6 for r in br]
    pressures = [r["air_pressure"] for r in br[1:]]
    w(f"| `pockets-breathing` | a bubble under a permeable cloth, lifted and pressed | air {fmt(min(amounts))}-{fmt(max(amounts))} cm^3, pressure {fmt(min(pressures) / 1e3, 5)}-{fmt(max(pressures) / 1e3, 5)} kPa | |")
    w("")
    def med(model, threads):
        v = sorted(b["particle_steps_per_second"] for run in pk_bench[model] for b in run
                   if b["threads"] == threads)
        return v[len(v) // 2]
    w("Speed on the bench workload (50 x 50, the thesis' spacing and step, a wet cloth settling "
      "onto the table; medians of three alternating runs): "
      f"{med('pockets', 1):.3g} particle-steps/s with pockets against {med('thesis', 1):.3g} "
      f"with the single bubble on one thread ({fmt(100 * med('pockets', 1) / med('thesis', 1))} %), "
      f"{med('pockets', 2):.3g} against {med('thesis', 2):.3g} on two "
      f"({fmt(100 * med('pockets', 2) / med('thesis', 2))} %). The cost is the sealing test and "
      "the region search each step; the search is skipped when no particle sealed or unsealed. "
      "The tests in `crates/wetcloth/tests/pockets.rs` hold the closed forms: a seeded pocket "
      "keeps its air to 1e-9 and P V = P_a N on every step, merges conserve air to 1e-9, a split "
      "keeps the pressure, a held pocket fills along Darcy's exponential within 1 %, and the "
      "middle lift needs at least 10x the corner's force.")
    w("")
    w(f"![seeded bubbles under a wet cloth]({img['pockets-bubbles']})")
    w(f"![the middle lifted: a vacuum pocket]({img['pockets-middle']})")
    w(f"![a corner peeled: open to the room]({img['pockets-corner']})")
    w("")

    w("## Beyond the thesis: wet cloth on meshes and moving colliders")
    w("")
    hd, bp, tl = m["head-drape"], m["ball-pull"], m["tilted-lift"]
    w("The pockets model measures the air against whatever the cloth seals on (the frustum "
      "between each cloth triangle and its footprint on the nearest sticky collider; eq. 3.10 "
      "on a plane, the radial shell over a sphere, tested in `crates/wetcloth/src/air/pockets.rs` "
      "and `crates/wetcloth/tests/{pockets,meshes}.rs`).")
    w("")
    w("| scene | what is measured | value |")
    w("|---|---|---|")
    w(f"| `head-drape` (5120-triangle head) | contact fraction, sealed pockets and their air at the end | "
      f"{fmt(hd[-1]['contact_fraction'])}, {int(hd[-1]['pocket_count'])}, {fmt(hd[-1]['trapped_air'] * 1e6)} cm^3 |")
    # The ball's suction lasts a few frames; a run without a pocket at any frame says so.
    sucked = [r["air_pressure"] for r in bp if r["pocket_count"] > 0]
    lowest = f"{fmt(min(sucked) / 1e3, 5)} kPa" if sucked else "no pocket at any frame"
    w(f"| `ball-pull` (a ball pulled out of the cloth) | lowest pocket pressure while the ball leaves | "
      f"{lowest} |")
    w(f"| `tilted-lift` (lifted 1.2 cm off a tilted mesh) | peak hand force against the vacuum | "
      f"{fmt(max(r['grab_force'] for r in tl))} N |")
    w("")
    w(f"![a wet cloth over the head]({img['head-drape']})")
    w("")

    w("## Beyond the thesis: cloths of any shape")
    w("")
    w("A cloth read from an OBJ file (`[cloth] mesh`): particle k is the file's vertex k, the "
      "springs run along every edge and across every interior edge with stiffnesses fitted to "
      "the grid's membrane, masses and areas are lumped by area, and both air models act over "
      "the mesh's triangles ([integrators.md](integrators.md#a-cloth-of-any-shape)). The meshes "
      "are made by `tools/make_cloth_meshes.py`; measured from each run's `metrics.csv` and "
      "`grabs.csv`:")
    w("")
    w("| scene | what is measured | value |")
    w("|---|---|---|")
    tp = grabs["towel-pinned"]
    last = max(r["frame"] for r in tp)
    held = [r for r in tp if r["frame"] == last][0]
    weight = 0.175 * 9.8
    w(f"| `towel-pinned` (609 particles, 50 x 70 cm, 175 g) | the held edge's force at the end "
      f"({int(held['particles'])} particles held) against the towel's weight | "
      f"{fmt(math.hypot(held['force_x'], held['force_y'], held['force_z']))} N against "
      f"{fmt(weight)} N |")
    lc, lm = m["towel-lift-corner"], m["towel-lift-middle"]
    pc, pm = max(r["grab_force"] for r in lc), max(r["grab_force"] for r in lm)
    w(f"| `towel-lift-corner` | peak hand force lifting a corner 1.5 cm (open to the room) | {fmt(pc)} N |")
    w(f"| `towel-lift-middle` | peak hand force lifting the middle 1.5 cm (a sealed pocket), "
      f"lowest pocket pressure | {fmt(pm)} N, "
      f"{fmt(min(r['air_pressure'] for r in lm) / 1e3, 5)} kPa |")
    w(f"| | middle / corner | {fmt(pm / pc)}x |")
    tc = m["tablecloth-round"]
    w(f"| `tablecloth-round` (841 particles, 60 cm radius, over a table's edge) | contact "
      f"fraction and sealed pockets at the end | {fmt(tc[-1]['contact_fraction'])}, "
      f"{int(tc[-1]['pocket_count'])} |")
    w("")
    w(f"![a towel pinned along its top edge]({img['towel-pinned']})")
    w(f"![a wet towel lifted by its middle]({img['towel-lift-middle']})")
    w(f"![a wet towel lifted by a corner]({img['towel-lift-corner']})")
    w(f"![a round tablecloth over a table's edge]({img['tablecloth-round']})")
    w("")

    w("## Table 4.2: speed against particle count")
    w("")
    w("The thesis drew one step per frame (Core i7-3930K, single-threaded, with rendering). "
      "wetcloth's `bench` times the step alone on this machine (2 cores), medians of timed "
      "windows, self-collision on, the thesis' time step 1/12000 s (real-time factor = "
      "simulated seconds per wall second).")
    w("")
    w("| particles | thesis steps/s | wetcloth steps/s, 1 thread | 2 threads | particle-steps/s (2 threads) | real-time factor (2 threads) | speed-up over the thesis |")
    w("|---|---|---|---|---|---|---|")
    by = {}
    for b in bench:
        by.setdefault(b["particles"], {})[b["threads"]] = b
    for n in sorted(by):
        one, two = by[n].get(1), by[n].get(2, by[n].get(1))
        thesis = one.get("thesis_steps_per_second") if one else None
        w(f"| {n} | {fmt(thesis) if thesis else '-'} | {fmt(one['steps_per_second'], 4) if one else '-'} | "
          f"{fmt(two['steps_per_second'], 4)} | {two['particle_steps_per_second']:.3g} | "
          f"{two['real_time_factor']:.3g} | "
          f"{fmt(two['steps_per_second'] / thesis) + 'x' if thesis else '-'} |")
    w("")
    linear = [b["particle_steps_per_second"] for b in bench if b["threads"] == 1]
    w(f"**Verdict: the thesis' linear growth of time with particle count holds** "
      f"(particle-steps per second stay within a factor {fmt(max(linear) / min(linear))} from "
      f"the smallest to the largest cloth, with one thread; the smallest cloths pay a fixed "
      f"per-step cost). The speed is two to three orders of magnitude higher: the thesis "
      f"spent most of its time in Bullet's collision detection and in drawing, wetcloth runs "
      f"the step as vectorised row loops on the grid (see `docs/performance.md`).")
    w("")
    # Sections measured by their own tools (the implicit integrator's, by
    # tools/implicit-scenes.sh and its tests) are kept from the previous document.
    KEPT = "## The implicit integrator"
    if DOC.exists() and KEPT in DOC.read_text():
        kept = DOC.read_text()
        w(kept[kept.index(KEPT):].rstrip("\n"))
        w("")
    DOC.write_text("\n".join(L))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    sys.exit(main())
