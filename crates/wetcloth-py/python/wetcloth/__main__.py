"""``python -m wetcloth sweep SCENE --vary KEY=V1,V2 ... --out sweep.csv``: what
``wetcloth sweep`` runs."""

from __future__ import annotations

import argparse
import sys

from ._errors import SceneError
from ._native import Scene, parse_value


def split_values(text: str) -> list[str]:
    """``V1,V2,...`` split at the commas outside brackets, braces and quotes
    (``[0.2,0.2],[0.3,0.3]`` is two values)."""
    parts, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(text):
        if quote:
            if c == quote:
                quote = ""
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="wetcloth sweep")
    sub = parser.add_subparsers(dest="command", required=True)
    sw = sub.add_parser("sweep", help="run every combination of some scene keys' values on Dask")
    sw.add_argument("scene")
    sw.add_argument("--vary", action="append", required=True, metavar="KEY=V1,V2,...")
    sw.add_argument("--scheduler", default=None, metavar="ADDR")
    sw.add_argument("--out", required=True, metavar="FILE")
    sw.add_argument("--runs", default=None, metavar="DIR")
    sw.add_argument("--quiet", "-q", action="store_true")
    args = parser.parse_args(argv)

    vary: dict[str, list] = {}
    for item in args.vary:
        key, eq, values = item.partition("=")
        if not eq or not key.strip() or not values.strip():
            print(f"error: --vary {item}: expected KEY=V1,V2,...", file=sys.stderr)
            return 2
        vary[key.strip()] = [parse_value(v) for v in split_values(values)]
    try:
        scene = Scene.from_file(args.scene)
        # An unknown key is refused before any run starts.
        for key in vary:
            scene.get(key)
    except SceneError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    from ._sweep import sweep

    table = sweep(scene, vary, scheduler=args.scheduler, runs=args.runs, progress=not args.quiet)
    table.to_csv(args.out, index=False)
    if not args.quiet:
        counts = table["status"].value_counts()
        summary = ", ".join(f"{counts.get(s, 0)} {s}" for s in ("complete", "failed", "invalid"))
        print(f"wetcloth sweep: {len(table)} runs ({summary}) -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
