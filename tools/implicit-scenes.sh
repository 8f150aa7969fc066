#!/bin/bash
# Runs every shipped scene with the implicit integrator at 1/600 s, and the thesis demo and the
# pinch scenes also at 1/120 s, and the explicit integrator at each scene's own step, one right
# after the other, printing one line per run: scene, integrator, step, wall seconds, and the
# measured quantities (peak hand force, final contact fraction, tent height, bubble volume and
# pressure, kinetic energy); SKIP_VERLET=1 leaves out the explicit runs.
# Usage: tools/implicit-scenes.sh [SCENE...] (default: scenes/*.toml).
# Build first: cargo build --release -p wetcloth-cli
set -u
bin=${WETCLOTH:-target/release/wetcloth}
tmp=$(mktemp -d)
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(scenes/*.toml)
one() { # scene integrator step
    local s=$1 integ=$2 dt=$3 name
    name=$(basename "$s" .toml)-$integ-$dt
    # The copy keeps file paths relative to the scene's own folder (a mesh collider's file).
    local dir
    dir=$(cd "$(dirname "$s")" && pwd)
    sed -e "s|^time_step = .*|time_step = $dt|" -e "/^integrator = /d" -e "s|^\[simulation\]|[simulation]\nintegrator = \"$integ\"|" \
        -e "s|^\(file *= *\"\)\([^/\"][^\"]*\"\)|\1$dir/\2|" \
        "$s" > "$tmp/$name.toml"
    local t0 t1 status
    t0=$(date +%s.%N)
    "$bin" run -q --threads "${THREADS:-1}" -o "$tmp/$name" "$tmp/$name.toml" 2>/dev/null
    status=$?
    t1=$(date +%s.%N)
    awk -F, -v n="$name" -v w="$(echo "$t1 - $t0" | bc)" -v st=$status '
        NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
        { f = $c["grab_force"]; if (f > peak) peak = f; last = $0 }
        END { split(last, v, ",");
              printf "%-40s status %d wall %7.1f s  peak_force %.4g  contact %.4g  height %.4g  volume %.4g  pressure %.7g  ke %.3g\n",
                     n, st, w, peak, v[c["contact_fraction"]], v[c["max_height"]], v[c["air_volume"]],
                     v[c["air_pressure"]], v[c["kinetic_energy"]] }' "$tmp/$name/metrics.csv"
}
for s in "${scenes[@]}"; do
    own=$(sed -n 's/^time_step = //p' "$s")
    [ -n "${SKIP_VERLET:-}" ] || one "$s" verlet "$own"
    one "$s" implicit 0.0016666666666666668
    case $(basename "$s") in
        air-400.toml|pinch-*.toml) one "$s" implicit 0.008333333333333333 ;;
    esac
done
rm -rf "$tmp"
