#!/usr/bin/env python3
"""Writes the held-out scenes irr's measurements name, built with assets/generate.py's writer.

Usage: python3 docs/make-held-out-scenes.py OUT_DIR

- white-metal-box.gltf: the Cornell box whose two blocks are a white metal (base colour 0.95,
  metallic 1), the tall one of GGX roughness 0.3 (a lobe no order up to 10 holds), the short
  one of 0.6 (one order 10 holds at most views): radiance caching's held-out box.
- indirect-room-far-ground.gltf: the indirect-lit room over a grey 10 km ground 100 m below it,
  which the camera never sees: lengths taken from the scene's bounds break there.

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


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    os.makedirs(sys.argv[1], exist_ok=True)
    g.HERE = sys.argv[1]
    white_metal_box()
    indirect_room_far_ground()


if __name__ == "__main__":
    main()
