#!/usr/bin/env python3
"""Writes the held-out scenes irr's measurements name, built with assets/generate.py's writer.

Usage: python3 docs/make-held-out-scenes.py OUT_DIR

- white-metal-box.gltf: the Cornell box whose two blocks are a white metal (base colour 0.95,
  metallic 1), the tall one of GGX roughness 0.3 (a lobe no order up to 10 holds), the short
  one of 0.6 (one order 10 holds at most views): radiance caching's held-out box.
- indirect-room-far-ground.gltf: the indirect-lit room over a grey 10 km ground 100 m below it,
  which the camera never sees: lengths taken from the scene's bounds break there.
- sphere-grid.gltf: 100 spheres of 16 128 triangles on a floor under an area light, each its
  own mesh and material (metallic and roughness across the grid) but all reading one POSITION,
  NORMAL and index accessor, as the Khronos sample MetalRoughSpheresNoTextures does: 1.6 M
  triangles drawn, 16 132 stored when repeats are instanced.
- forest.gltf: a bush of 99 904 triangles placed 1024 times by EXT_mesh_gpu_instancing (turned,
  scaled, on a 32 × 32 grid) on a ground: 1.02·10⁸ triangles from 10⁵ unique ones. Render it
  under a sky (`--background 0.8,0.9,1.0`).

The defaults were not tuned on either (`cargo xtask compare` lists them as held out). Only the
standard library and assets/generate.py are used; the output is deterministic.
"""

import os
import sys

# No __pycache__ in assets/.
sys.dont_write_bytecode = True
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "assets"))
import generate as g  # noqa: E402

WHITE_METAL = (0.95, 0.95, 0.95)


def white_metal_box():
    b = g.Builder()
    white, red, green = g.cornell_colours(b)
    tall = b.glossy_material("tall block, white metal", WHITE_METAL, 1.0, 0.3)
    short = b.glossy_material("short block, white metal", WHITE_METAL, 1.0, 0.6)
    light = b.material("light", g.LIGHT_ALBEDO, emission=g.LIGHT_RADIANCE, double_sided=False)
    blocks = {"short_block": short, "tall_block": tall}
    surfaces = [(n, blocks.get(n, m)) for (n, m) in g.room_surfaces(white, red, green)]
    g.add_cornell_surfaces(b, surfaces + [("light", light)])
    g.cornell_camera(b)
    g.write_scene(b, "white-metal-box", "held out: the Cornell box with white-metal blocks, metres")


def indirect_room_far_ground():
    write = g.write_scene

    def with_ground(b, stem, note):
        s = 5000.0
        points = [(-s, -100.0, -s), (-s, -100.0, s), (s, -100.0, s), (s, -100.0, -s)]
        # Material 0: the room's white (cornell_colours adds it first).
        b.mesh("ground", points, [(0, 1, 2), (0, 2, 3)], 0, component_type=5125)
        write(b, stem + "-far-ground", note + ", over a 10 km ground 100 m below")

    g.write_scene = with_ground
    try:
        g.indirect_room()
    finally:
        g.write_scene = write


def sphere_triangles(rings, segments):
    """The triangles of a latitude-longitude sphere whose vertex (i, j), ring i of rings + 1
    from the north pole, segment j, is i * segments + j; no sliver triangles at the poles."""
    triangles = []
    for i in range(rings):
        for j in range(segments):
            a, c = i * segments + j, i * segments + (j + 1) % segments
            d, e = a + segments, c + segments
            if i > 0:
                triangles.append((a, c, d))
            if i < rings - 1:
                triangles.append((c, e, d))
    return triangles


def sphere_grid():
    import math

    b = g.Builder()
    floor = b.material("floor", (0.6, 0.6, 0.6))
    light = b.material("light", g.LIGHT_ALBEDO, emission=(8.0, 8.0, 8.0), double_sided=False)
    rings, segments, radius = 64, 128, 0.4
    points, normals = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2.0 * math.pi * j / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            normals.append(n)
            points.append(tuple(radius * c for c in n))
    triangles = sphere_triangles(rings, segments)
    # One accessor of each kind, read by every sphere's mesh (outward windings: (c - a) x (d - a)
    # points away from the centre with y up at theta = 0).
    shared = {
        "attributes": {"POSITION": b.positions(points), "NORMAL": b.positions(normals)},
        "indices": b.indices(triangles, 5125),
        "mode": 4,
    }
    for k in range(100):
        row, col = divmod(k, 10)
        m = b.glossy_material(f"sphere {k}", (0.8, 0.6, 0.3), row / 9.0, 0.05 + 0.95 * col / 9.0)
        b.meshes.append({"name": f"sphere {k}", "primitives": [dict(shared, material=m)]})
        b.nodes.append(
            {"name": f"sphere {k}", "mesh": len(b.meshes) - 1,
             "translation": [col - 4.5, radius, row - 4.5]}
        )
    s = 8.0
    b.mesh("floor", [(-s, 0, -s), (-s, 0, s), (s, 0, s), (s, 0, -s)], [(0, 1, 2), (0, 2, 3)], floor)
    h, l = 6.0, 2.0
    b.mesh("light", [(-l, h, -l), (l, h, -l), (l, h, l), (-l, h, l)], [(0, 1, 2), (0, 2, 3)], light)
    # Looking down the grid from above its near edge: -Z turned 35 degrees down about X.
    a = math.radians(-35.0) / 2.0
    b.camera("camera", 0.8, 1.0, (0.0, 5.5, 9.0), (math.sin(a), 0.0, 0.0, math.cos(a)))
    g.write_scene(b, "sphere-grid", "held out: 100 spheres sharing their accessors, metres")


def forest():
    import math
    import struct

    b = g.Builder()
    ground = b.material("ground", (0.35, 0.3, 0.25))
    leaves = b.material("leaves", (0.25, 0.5, 0.2))
    n = 224
    points = []
    for i in range(n + 1):
        theta = math.pi * i / n
        for j in range(n):
            phi = 2.0 * math.pi * j / n
            # A lumpy ball: a few fixed harmonics of the direction.
            r = 1.0 + 0.12 * math.sin(5 * theta) * math.cos(3 * phi) + 0.05 * math.sin(17 * phi)
            points.append(
                (r * math.sin(theta) * math.cos(phi), 1.0 + r * math.cos(theta),
                 r * math.sin(theta) * math.sin(phi))
            )
    triangles = sphere_triangles(n, n)
    b.meshes.append({"name": "bush", "primitives": [{
        "attributes": {"POSITION": b.positions(points)},
        "indices": b.indices(triangles, 5125), "material": leaves, "mode": 4}]})
    translations, rotations, scales = [], [], []
    state = 12345
    for k in range(1024):
        row, col = divmod(k, 32)
        state = (1103515245 * state + 12345) % 2**31
        u = state / 2**31
        translations.append((3.0 * (col - 15.5) + u, 0.0, 3.0 * (row - 15.5) - u))
        a = math.pi * u
        rotations.append((0.0, math.sin(a), 0.0, math.cos(a)))
        scales.append((0.8 + 0.4 * u, 0.7 + 0.6 * (1.0 - u), 0.8 + 0.4 * u))
    view = b._view(b"".join(struct.pack("<4f", *q) for q in rotations), None)
    b.views[view].pop("target")
    b.accessors.append({"bufferView": view, "componentType": 5126, "count": 1024, "type": "VEC4"})
    rotation = len(b.accessors) - 1
    b.nodes.append({"name": "bushes", "mesh": len(b.meshes) - 1, "extensions": {
        "EXT_mesh_gpu_instancing": {"attributes": {
            "TRANSLATION": b.positions(translations), "ROTATION": rotation,
            "SCALE": b.positions(scales)}}}})
    b.extensions_used.add("EXT_mesh_gpu_instancing")
    s = 60.0
    b.mesh("ground", [(-s, 0, -s), (-s, 0, s), (s, 0, s), (s, 0, -s)], [(0, 1, 2), (0, 2, 3)], ground)
    a = math.radians(-25.0) / 2.0
    b.camera("camera", 0.9, 1.5, (0.0, 14.0, 52.0), (math.sin(a), 0.0, 0.0, math.cos(a)))
    g.write_scene(b, "forest", "held out: 1024 instances of a 10^5-triangle bush, metres")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    os.makedirs(sys.argv[1], exist_ok=True)
    g.HERE = sys.argv[1]
    white_metal_box()
    indirect_room_far_ground()
    sphere_grid()
    forest()


if __name__ == "__main__":
    main()
