#!/usr/bin/env bash
# The general path on a mesh against the grid's fast path on the same particles: the built-in
# N x N grid and a mesh of the same particles (tools/make_cloth_meshes.py --grid N: one diagonal
# per cell), the same cloth (30 cm, the thesis' particle mass), lying on the table with a hand
# lifting its middle, air off (the springs, gravity, contacts and the hand: the step itself).
# Explicit at 1/12000 s and implicit at 1/600 s, each on 1 and 2 threads, in alternating rounds;
# prints each configuration's median steps/s, particle-steps/s and CG iterations per step.
#
#   tools/mesh-speed.sh [BINARY] [ROUNDS] [SIZES...]
#
# BINARY defaults to target/release/wetcloth, ROUNDS to 5, SIZES to "50 100".
set -euo pipefail
bin=${1:-target/release/wetcloth}
rounds=${2:-5}
shift 2 || true
sizes=${*:-50 100}
here=$(cd "$(dirname "$0")" && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

for n in $sizes; do
  python3 "$here/make_cloth_meshes.py" --grid "$n" "$dir/grid-$n.obj"
  mass=$(python3 -c "print(0.02 * $n * $n / 2500)")
  for kind in grid mesh; do
    for integ in verlet implicit; do
      f="$dir/$kind-$n-$integ.toml"
      {
        echo "name = \"$kind-$n-$integ\""
        echo "[simulation]"
        echo "duration = 1.0"
        if [ "$integ" = verlet ]; then echo "time_step = 8.333333333333333e-5"; else echo "time_step = 0.0016666666666666668"; fi
        echo "integrator = \"$integ\""
        echo "[cloth]"
        if [ "$kind" = grid ]; then
          echo "size = [0.3, 0.3]"
          echo "resolution = [$n, $n]"
        else
          echo "mesh = \"grid-$n.obj\""
        fi
        echo "position = [0.0, 0.00075, 0.0]"
        echo "mass = $mass"
        echo "damping = 2.0"
        echo "self_collision = false"
        echo "[air]"
        echo "enabled = false"
        echo "[[grab]]"
        echo "vertex = $(( (n / 2) * n + n / 2 ))"
        echo 'keys = [{ time = 0.0, offset = [0.0, 0.0, 0.0] }, { time = 1.0, offset = [0.0, 0.05, 0.0] }]'
      } > "$f"
    done
  done
done

results="$dir/results.txt"
: > "$results"
for round in $(seq "$rounds"); do
  for n in $sizes; do
    for integ in verlet implicit; do
      for threads in 1 2; do
        for kind in grid mesh; do
          line=$("$bin" bench --scene "$dir/$kind-$n-$integ.toml" --threads "$threads" --seconds 3 | sed -n 2p)
          echo "$kind $n $integ $threads $line" >> "$results"
        done
      done
    done
  done
  echo "round $round of $rounds done" >&2
done

python3 - "$results" <<'EOF'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    w = line.split()
    kind, n, integ, threads = w[0], int(w[1]), w[2], int(w[3])
    particles, steps, cg = int(w[4]), float(w[8]), float(w[10])
    rows.setdefault((n, integ, threads, kind), []).append((steps, particles, cg))
print("| particles | integrator | threads | grid steps/s | mesh steps/s | mesh / grid | CG iter/step grid | CG iter/step mesh |")
print("|---|---|---|---|---|---|---|---|")
for (n, integ, threads) in sorted({k[:3] for k in rows}):
    g = rows[(n, integ, threads, "grid")]
    m = rows[(n, integ, threads, "mesh")]
    gs, ms = statistics.median(r[0] for r in g), statistics.median(r[0] for r in m)
    gc, mc = statistics.median(r[2] for r in g), statistics.median(r[2] for r in m)
    print(f"| {g[0][1]} | {integ} | {threads} | {gs:.0f} | {ms:.0f} | {ms / gs:.2f} | {gc:.1f} | {mc:.1f} |")
EOF
