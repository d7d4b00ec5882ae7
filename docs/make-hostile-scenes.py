#!/usr/bin/env python3
"""Writes the large hostile scenes into a folder, for measuring the loader's time and
peak memory by hand (see docs/fuzzing.md). The regression tests generate their own, smaller,
versions of these files; this script makes the full-size ones.

    python3 docs/make-hostile-scenes.py OUT_DIR
"""
import base64
import json
import os
import struct
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "hostile"
os.makedirs(out, exist_ok=True)


def write(name, doc):
    with open(os.path.join(out, name), "w") as f:
        json.dump(doc, f, separators=(",", ":"))


TRI = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
URI = "data:application/octet-stream;base64," + base64.b64encode(TRI).decode()


def one_triangle():
    return {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": URI}],
    }


# Allocation bombs: an accessor without bufferView, with a sparse block, and a huge count.
for name, count in [("sparse-2-33", 2**33), ("sparse-2-28", 2**28), ("sparse-1e8", 10**8)]:
    d = one_triangle()
    d["accessors"] = [{
        "componentType": 5126, "count": count, "type": "VEC3",
        "sparse": {"count": 1,
                   "indices": {"bufferView": 0, "componentType": 5125},
                   "values": {"bufferView": 0}},
    }]
    write(name + ".gltf", d)

# A chain of 10^6 nodes, each the only child of the one before, the last holding the mesh.
n = 10**6
d = one_triangle()
d["nodes"] = [{"children": [i + 1], "translation": [0, 0, 1e-6]} for i in range(n - 1)] + [{"mesh": 0}]
write("chain-1e6.gltf", d)

# Nested triangles with one centroid, each 1.0001 times the one before (PLOC's hang).
for n in [10**4, 4 * 10**4, 10**5]:
    c = (0.0, -1.0 / 3.0, 0.0)
    base = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)]
    data = bytearray()
    s = 1.0
    for _ in range(n):
        for p in base:
            data += struct.pack("<3f", *(c[k] + (p[k] - c[k]) * s for k in range(3)))
        s *= 1.0001
    with open(os.path.join(out, f"nested-{n}.bin"), "wb") as f:
        f.write(data)
    d = one_triangle()
    d["accessors"] = [{"bufferView": 0, "componentType": 5126, "count": 3 * n, "type": "VEC3"}]
    d["bufferViews"] = [{"buffer": 0, "byteLength": len(data)}]
    d["buffers"] = [{"byteLength": len(data), "uri": f"nested-{n}.bin"}]
    d["materials"] = [{"emissiveFactor": [1, 1, 1]}]
    d["meshes"][0]["primitives"][0]["material"] = 0
    write(f"nested-{n}.gltf", d)
