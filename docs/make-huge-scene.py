#!/usr/bin/env python3
"""Writes a glTF binary (.glb) with about N triangles for irr's huge-scene measurements.

Usage: python3 docs/make-huge-scene.py N OUT.glb [room]

The scene: a square emitter of 1 m² at y = 2 facing down, over a 2 m × 2 m heightfield of
k × k quads (2k² ≥ N triangles, k = ceil(sqrt(N / 2))) whose height is a smooth bump field, so the
BVH sees a real surface rather than a flat sheet, and a camera looking at it from above. Vertices
are shared (a grid of (k+1)² positions) the way an exporter writes a mesh, so the file holds
12 bytes per vertex and 12 per triangle: about 18 MB for 10⁶ triangles.

With `room`, the heightfield is the floor of a closed room (four walls and a ceiling, 10 more
triangles, the heightfield's material) and the camera stands inside it: paths then bounce about
ten times instead of escaping after one or two, as in an interior (the case the batched paths are for).

Only the standard library is used; the output is deterministic.
"""

import json
import math
import struct
import sys


def main():
    n = int(sys.argv[1])
    out = sys.argv[2]
    room = sys.argv[3:] == ["room"]
    k = max(1, math.ceil(math.sqrt(n / 2)))
    pos = bytearray()
    for j in range(k + 1):
        z = -1.0 + 2.0 * j / k
        for i in range(k + 1):
            x = -1.0 + 2.0 * i / k
            y = 0.05 * math.sin(7.0 * x) * math.cos(5.0 * z)
            pos += struct.pack("<3f", x, y, z)
    idx = bytearray()
    for j in range(k):
        for i in range(k):
            a = j * (k + 1) + i
            b, c, d = a + 1, a + k + 1, a + k + 2
            # Counter-clockwise seen from +y.
            idx += struct.pack("<6I", a, c, b, b, c, d)
    light_pos = struct.pack("<12f", -0.5, 2, -0.5, 0.5, 2, -0.5, 0.5, 2, 0.5, -0.5, 2, 0.5)
    light_idx = struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    blobs = [bytes(pos), bytes(idx), light_pos, light_idx]
    # The room: corners of a box around the heightfield, and its faces wound to face inwards
    # (no floor: the heightfield is the floor).
    corners = [(x, y, z) for z in (-1, 1) for y in (-0.1, 2.1) for x in (-1, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 2, 6, 4), (1, 5, 7, 3), (2, 3, 7, 6)]
    if room:
        blobs.append(b"".join(struct.pack("<3f", *c) for c in corners))
        blobs.append(b"".join(struct.pack("<6I", a, b, c, a, c, d) for a, b, c, d in faces))
    bin_ = bytearray()
    views = []
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(b)})
        bin_ += b
        while len(bin_) % 4:
            bin_ += b"\0"
    nv, nt = (k + 1) ** 2, 2 * k * k
    camera = [0, 1.5, 0.95] if room else [0, 2.5, 2.5]
    doc = {
        "asset": {"version": "2.0", "generator": "irr docs/make-huge-scene.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"mesh": 1},
            {"camera": 0, "translation": camera, "rotation": [-0.3826834, 0, 0, 0.9238795]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0}},
            {
                "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
                "emissiveFactor": [1, 1, 1],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}},
            },
        ],
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 1}]},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
             "min": [-1, -0.05, -1], "max": [1, 0.05, 1]},
            {"bufferView": 1, "componentType": 5125, "count": 3 * nt, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-0.5, 2, -0.5], "max": [0.5, 2, 0.5]},
            {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": len(bin_)}],
    }
    if room:
        doc["scenes"][0]["nodes"].append(3)
        doc["nodes"].append({"mesh": 2})
        doc["meshes"].append(
            {"primitives": [{"attributes": {"POSITION": 4}, "indices": 5, "material": 0}]}
        )
        doc["accessors"] += [
            {"bufferView": 4, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-1, -0.1, -1], "max": [1, 2.1, 1]},
            {"bufferView": 5, "componentType": 5125, "count": 30, "type": "SCALAR"},
        ]
        nt += 10
    js = json.dumps(doc, separators=(",", ":")).encode()
    while len(js) % 4:
        js += b" "
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)
    print(f"{out}: {nt} triangles, {nv} vertices, {total} bytes")


if __name__ == "__main__":
    main()
