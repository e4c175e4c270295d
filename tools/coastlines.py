#!/usr/bin/env python3
"""Converts Natural Earth land outlines from world-atlas TopoJSON into hdrvis coastline files.

Source: the npm package world-atlas@2 (land-110m.json, land-50m.json), a TopoJSON form of the
Natural Earth 1:110m and 1:50m land polygons, which are in the public domain
(https://www.naturalearthdata.com/about/terms-of-use/). Get it with `npm pack world-atlas@2` and
untar it. Every arc of the land topology is a piece of coast; the straight edges the polygons
need to close at the antimeridian and along the south pole are not coast, so the polylines are
cut there.

Usage: python3 tools/coastlines.py PACKAGE_DIR OUT_DIR  (writes ne_110m.bin and ne_50m.bin)

Format (little-endian): b"HDCL", u32 version 1, u32 polyline count P, u32 point count N, P u32
point counts, then N pairs of i32 (longitude, latitude) in micro-degrees.
"""
import json
import os
import struct
import sys


def arcs_in_degrees(topo):
    """The topology's arcs, delta-decoded and de-quantised, as lists of (lon, lat)."""
    sx, sy = topo["transform"]["scale"]
    tx, ty = topo["transform"]["translate"]
    out = []
    for arc in topo["arcs"]:
        x = y = 0
        pts = []
        for dx, dy in arc:
            x += dx
            y += dy
            pts.append((x * sx + tx, y * sy + ty))
        out.append(pts)
    return out


def not_coast(a, b):
    """Whether the segment a-b is a closing edge: along the antimeridian or the south pole."""
    on_meridian = abs(abs(a[0]) - 180.0) < 1e-3 and abs(abs(b[0]) - 180.0) < 1e-3
    on_pole = a[1] < -89.9 and b[1] < -89.9
    return on_meridian or on_pole


def coast_pieces(arc):
    """Cuts an arc at its closing edges; pieces of fewer than two points are dropped."""
    pieces, cur = [], [arc[0]]
    for a, b in zip(arc, arc[1:]):
        if not_coast(a, b):
            if len(cur) > 1:
                pieces.append(cur)
            cur = [b]
        else:
            cur.append(b)
    if len(cur) > 1:
        pieces.append(cur)
    return pieces


def write(polylines, path):
    micro = [[(round(lon * 1e6), round(lat * 1e6)) for lon, lat in p] for p in polylines]
    n = sum(len(p) for p in micro)
    with open(path, "wb") as f:
        f.write(b"HDCL" + struct.pack("<3I", 1, len(micro), n))
        f.write(struct.pack("<%dI" % len(micro), *[len(p) for p in micro]))
        for p in micro:
            f.write(struct.pack("<%di" % (2 * len(p)), *[c for xy in p for c in xy]))
    print(f"{path}: {len(micro)} polylines, {n} points, {os.path.getsize(path)} bytes")


def main():
    src, out = sys.argv[1], sys.argv[2]
    for res in ("110m", "50m"):
        with open(os.path.join(src, f"land-{res}.json")) as f:
            topo = json.load(f)
        lines = [p for arc in arcs_in_degrees(topo) for p in coast_pieces(arc)]
        write(lines, os.path.join(out, f"ne_{res}.bin"))


if __name__ == "__main__":
    main()
