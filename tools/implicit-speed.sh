#!/bin/bash
# Speed of the implicit integrator against the explicit one on whole scenes: for each scene,
# ROUNDS rounds (default 3) of `wetcloth bench --scene` with the explicit integrator at the
# scene's own step, then the implicit one at 1/600 s and 1/120 s, one right after the other,
# on THREADS threads (default 1); prints the median wall seconds of each and the speed-up
# (explicit wall time over implicit wall time, for the same simulated time).
# Usage: tools/implicit-speed.sh [SCENE...] (default: the pinch scenes).
# Build first: cargo build --release -p wetcloth-cli
set -u
bin=${WETCLOTH:-target/release/wetcloth}
rounds=${ROUNDS:-3}
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(scenes/pinch-center.toml scenes/pinch-two.toml)
tmp=$(mktemp -d)
wall() { # scene, then bench options: prints the wall seconds
    "$bin" bench -q --threads "${THREADS:-1}" --seconds 3600 --scene "$@" --json "$tmp/b.json" &&
        python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[0]['measured_seconds'])" "$tmp/b.json"
}
median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
printf "%-28s %12s %14s %14s %10s %10s\n" scene "verlet s" "implicit/600 s" "implicit/120 s" "x at 600" "x at 120"
for s in "${scenes[@]}"; do
    : > "$tmp/v"; : > "$tmp/i600"; : > "$tmp/i120"
    for _ in $(seq "$rounds"); do
        wall "$s" --integrator verlet >> "$tmp/v"
        wall "$s" --integrator implicit --time-step 0.0016666666666666668 >> "$tmp/i600"
        wall "$s" --integrator implicit --time-step 0.008333333333333333 >> "$tmp/i120"
    done
    v=$(median < "$tmp/v"); a=$(median < "$tmp/i600"); b=$(median < "$tmp/i120")
    printf "%-28s %12.3f %14.3f %14.3f %9.1fx %9.1fx\n" "$(basename "$s")" "$v" "$a" "$b" \
        "$(echo "$v / $a" | bc -l)" "$(echo "$v / $b" | bc -l)"
done
rm -rf "$tmp"
