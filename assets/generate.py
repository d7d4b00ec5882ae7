#!/usr/bin/env python3
"""Writes irr's scenes in assets/ as glTF 2.0 (metres, +Y up, right-handed).

Run from anywhere with `python3 assets/generate.py`; it rewrites, next to itself:

- cornell-box.gltf + cornell-box.bin: the default scene, the Cornell box from Cornell's
  published "Cornell Box Data" (geometry in mm, converted to metres), with the camera as a glTF
  perspective camera. External buffer.
- indirect-room.gltf + indirect-room.bin: the Cornell box lit only indirectly: its light is
  replaced by an uplight, a panel under the ceiling that emits upwards, so apart from the
  patch it lights on the ceiling, everything the camera sees is lit by bounced light. Same
  camera, colours and geometry otherwise. External buffer, as the Cornell box.
- textured-room.gltf + textured-room.bin + textured-room-{floor,back-wall,blocks}.png: the
  Cornell box (with its own light) with base-colour textures carrying fine detail: parquet on
  the floor, glyphs and stripes on the back wall, a checker on the blocks. External buffer
  and PNG files.
- glossy-room.gltf + glossy-room.bin: the Cornell box with glTF metallic-roughness materials
  (rough gold and glossy plastic blocks, a rough dielectric floor, the textured room's poster on
  the back wall). External buffer; the poster is textured-room-back-wall.png.
- cornell-dolly.gltf + cornell-dolly.bin: the Cornell box whose camera an animation dollies
  10 cm to the right over 1 s (a LINEAR translation channel), for walkthroughs.
- cornell-push.gltf + cornell-push.bin: the same box, its camera pushed 60 cm in towards the
  back wall over 1 s (a walkthrough whose last frames need finer records than its first).
- metal-floor-room.gltf + metal-floor-room.bin: the glossy room with a rough metal floor
  (roughness 0.8), whose lobe low-order spherical harmonics hold (radiance caching).
- detail-room.gltf + detail-room.bin + detail-room-{floor-normal,lattice}.png: the glossy room
  with surface detail: a normal texture of bevelled tiles on the floor (normalTexture, tangents
  left to the renderer) and a wooden lattice standing in front of the back wall, cut out by its
  RGBA base colour texture's alpha (alphaMode MASK). External buffer and PNG files.
- furnace.glb: the white furnace, a closed sphere with albedo RHO and emission LE: every pixel sees
  LE / (1 - RHO) (with unbounded depth). Binary glTF.
- disk-light.gltf: a disk light of radius R at height H over a large diffuse plane; the irradiance
  on the axis is E = pi L r^2 / (r^2 + h^2). Buffer embedded as a data URI.
- ao-plane.gltf: one plane and nothing above it, no emitter: ambient occlusion is exactly 1.
  Buffer embedded as a data URI.

Only the standard library is used (json, struct, base64, math, zlib). The output is
deterministic: running the script twice gives the same bytes, so the committed files can be
checked by re-running it and asking git for a diff. (The PNGs avoid zlib's compressor, whose
output may vary between zlib builds; zlib only supplies the CRC-32 and Adler-32 checksums.)
"""

import base64
import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

# ---------------------------------------------------------------------------------------------
# Building glTF documents
# ---------------------------------------------------------------------------------------------


class Builder:
    """Collects binary data, accessors and meshes for one glTF document."""

    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []
        self.meshes = []
        self.materials = []
        self.nodes = []
        self.cameras = []
        self.images = []
        self.samplers = []
        self.textures = []
        self.animations = []
        self.extensions_used = set()

    def _align(self, n):
        while len(self.data) % n:
            self.data.append(0)

    def _view(self, payload, target):
        self._align(4)
        offset = len(self.data)
        self.data.extend(payload)
        self.views.append(
            {"buffer": 0, "byteOffset": offset, "byteLength": len(payload), "target": target}
        )
        return len(self.views) - 1

    def texcoords(self, uvs):
        """TEXCOORD_0: float (u, v) per vertex, glTF's convention ((0, 0) is the image's top-left
        texel corner, v grows down the rows)."""
        payload = b"".join(struct.pack("<2f", *uv) for uv in uvs)
        view = self._view(payload, 34962)  # ARRAY_BUFFER
        self.accessors.append(
            {"bufferView": view, "componentType": 5126, "count": len(uvs), "type": "VEC2"}
        )
        return len(self.accessors) - 1

    def texture(self, name, uri, mag_filter):
        """A texture reading the image file `uri` (next to the .gltf) through a sampler with
        magFilter `mag_filter` (9728 NEAREST, 9729 LINEAR), wrap REPEAT on both axes. minFilter
        is set equal to magFilter: irr has no mip maps and warns about any other minFilter."""
        self.images.append({"name": name, "uri": uri, "mimeType": "image/png"})
        sampler = {
            "magFilter": mag_filter,
            "minFilter": mag_filter,
            "wrapS": 10497,  # REPEAT
            "wrapT": 10497,
        }
        if sampler not in self.samplers:
            self.samplers.append(sampler)
        self.textures.append(
            {"name": name, "source": len(self.images) - 1, "sampler": self.samplers.index(sampler)}
        )
        return len(self.textures) - 1

    def positions(self, points):
        payload = b"".join(struct.pack("<3f", *p) for p in points)
        view = self._view(payload, 34962)  # ARRAY_BUFFER
        # min/max are required for POSITION; computed from the values as stored (f32).
        stored = [struct.unpack("<3f", struct.pack("<3f", *p)) for p in points]
        lo = [min(p[i] for p in stored) for i in range(3)]
        hi = [max(p[i] for p in stored) for i in range(3)]
        self.accessors.append(
            {
                "bufferView": view,
                "componentType": 5126,  # FLOAT
                "count": len(points),
                "type": "VEC3",
                "min": lo,
                "max": hi,
            }
        )
        return len(self.accessors) - 1

    def indices(self, triangles, component_type):
        fmt = {5121: "<B", 5123: "<H", 5125: "<I"}[component_type]
        flat = [i for t in triangles for i in t]
        payload = b"".join(struct.pack(fmt, i) for i in flat)
        view = self._view(payload, 34963)  # ELEMENT_ARRAY_BUFFER
        self.accessors.append(
            {
                "bufferView": view,
                "componentType": component_type,
                "count": len(flat),
                "type": "SCALAR",
            }
        )
        return len(self.accessors) - 1

    def material(
        self, name, albedo, emission=(0.0, 0.0, 0.0), double_sided=True, texture=None
    ):
        """A Lambertian material: glTF's metallic-roughness model with metallic 0 and
        KHR_materials_specular's specularFactor 0, which removes the dielectric's specular layer
        and leaves the Lambertian base of albedo baseColorFactor.

        `emission` is the emitted radiance (W sr^-1 m^-2 per channel); glTF clamps emissiveFactor
        to [0, 1], so a brighter emission is written as emissiveFactor = emission / max(emission)
        times KHR_materials_emissive_strength = max(emission). `texture` (an index from
        `texture()`) becomes the baseColorTexture, read through TEXCOORD_0; the albedo is then
        baseColorFactor times the texture's (linear) colour.
        """
        return self.glossy_material(
            name, albedo, 0.0, 1.0, specular=0.0, emission=emission,
            double_sided=double_sided, texture=texture,
        )

    def glossy_material(
        self, name, base, metallic, roughness, specular=1.0, emission=(0.0, 0.0, 0.0),
        double_sided=True, texture=None, normal_texture=None, alpha_cutoff=None,
    ):
        """glTF's metallic-roughness material (specularFactor 1 is the specification's own
        dielectric; other values are written as KHR_materials_specular). See `material()` for
        `emission` and `texture`. `normal_texture` (an index from `texture()`, its image written
        by `write_normal_texture()`) becomes the normalTexture, scale 1, read through
        TEXCOORD_0. `alpha_cutoff` makes the material a cut-out, alphaMode MASK with that
        alphaCutoff: the surface is absent where the base colour's alpha (the texture's alpha
        channel, which `write_rgba_texture()` writes) is below it."""
        m = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [base[0], base[1], base[2], 1.0],
                "metallicFactor": metallic,
                "roughnessFactor": roughness,
            },
            "doubleSided": double_sided,
        }
        extensions = {}
        if specular != 1.0:
            extensions["KHR_materials_specular"] = {"specularFactor": specular}
            self.extensions_used.add("KHR_materials_specular")
        if texture is not None:
            m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": texture, "texCoord": 0}
        if normal_texture is not None:
            m["normalTexture"] = {"index": normal_texture, "texCoord": 0, "scale": 1.0}
        if alpha_cutoff is not None:
            m["alphaMode"] = "MASK"
            m["alphaCutoff"] = alpha_cutoff
        peak = max(emission)
        if peak > 0.0:
            m["emissiveFactor"] = [e / peak for e in emission]
            if peak != 1.0:
                extensions["KHR_materials_emissive_strength"] = {"emissiveStrength": peak}
                self.extensions_used.add("KHR_materials_emissive_strength")
        if extensions:
            m["extensions"] = extensions
        self.materials.append(m)
        return len(self.materials) - 1

    def mesh(self, name, points, triangles, material, component_type=5123, uvs=None):
        check_indices(points, triangles, component_type)
        prim = {
            "attributes": {"POSITION": self.positions(points)},
            "indices": self.indices(triangles, component_type),
            "material": material,
            "mode": 4,  # TRIANGLES
        }
        if uvs is not None:
            assert len(uvs) == len(points), (name, len(uvs), len(points))
            prim["attributes"]["TEXCOORD_0"] = self.texcoords(uvs)
        self.meshes.append({"name": name, "primitives": [prim]})
        node = {"name": name, "mesh": len(self.meshes) - 1}
        self.nodes.append(node)
        return len(self.nodes) - 1

    def camera(self, name, yfov, aspect, translation, rotation):
        self.cameras.append(
            {
                "name": name,
                "type": "perspective",
                "perspective": {"yfov": yfov, "aspectRatio": aspect, "znear": 0.001},
            }
        )
        self.nodes.append(
            {
                "name": name,
                "camera": len(self.cameras) - 1,
                "translation": list(translation),
                "rotation": list(rotation),
            }
        )
        return len(self.nodes) - 1

    def animate_translation(self, node, times, translations):
        """A LINEAR animation of `node`'s translation through `translations` at `times` (s)."""
        inputs = b"".join(struct.pack("<f", t) for t in times)
        view = self._view(inputs, None)
        self.views[view].pop("target")
        stored = [struct.unpack("<f", struct.pack("<f", t))[0] for t in times]
        self.accessors.append(
            {"bufferView": view, "componentType": 5126, "count": len(times), "type": "SCALAR",
             "min": [min(stored)], "max": [max(stored)]}
        )
        outputs = b"".join(struct.pack("<3f", *p) for p in translations)
        view = self._view(outputs, None)
        self.views[view].pop("target")
        self.accessors.append(
            {"bufferView": view, "componentType": 5126, "count": len(translations), "type": "VEC3"}
        )
        n = len(self.accessors)
        self.animations.append(
            {
                "channels": [{"sampler": 0, "target": {"node": node, "path": "translation"}}],
                "samplers": [{"input": n - 2, "output": n - 1, "interpolation": "LINEAR"}],
            }
        )

    def document(self, generator_note, buffer_uri):
        self._align(4)
        buffer = {"byteLength": len(self.data)}
        if buffer_uri is not None:
            buffer["uri"] = buffer_uri
        doc = {
            "asset": {"version": "2.0", "generator": "irr assets/generate.py: " + generator_note},
            "scene": 0,
            "scenes": [{"nodes": list(range(len(self.nodes)))}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [buffer],
        }
        if self.cameras:
            doc["cameras"] = self.cameras
        if self.textures:
            doc["images"] = self.images
            doc["samplers"] = self.samplers
            doc["textures"] = self.textures
        if self.extensions_used:
            doc["extensionsUsed"] = sorted(self.extensions_used)
        if self.animations:
            doc["animations"] = self.animations
        return doc


def check_indices(points, triangles, component_type):
    limit = {5121: 0xFF, 5123: 0xFFFF, 5125: 0xFFFFFFFF}[component_type]
    for t in triangles:
        for i in t:
            assert 0 <= i < len(points) and i <= limit, (i, len(points), component_type)


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def face_normal(points, t):
    """The front-face direction glTF defines: counter-clockwise winding, (p1 - p0) x (p2 - p0)."""
    p0, p1, p2 = (points[i] for i in t)
    return cross(sub(p1, p0), sub(p2, p0))


def write_gltf(path, doc):
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        json.dump(doc, f, indent=1, sort_keys=True)
        f.write("\n")


def write_scene(b, stem, note):
    """Writes the builder's document as <stem>.gltf with its buffer in <stem>.bin, next to this
    script."""
    doc = b.document(note, stem + ".bin")
    write_gltf(os.path.join(HERE, stem + ".gltf"), doc)
    with open(os.path.join(HERE, stem + ".bin"), "wb") as f:
        f.write(bytes(b.data))


def write_glb(path, doc, data):
    """A binary glTF: 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with 0."""
    text = json.dumps(doc, sort_keys=True, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    data = bytes(data) + b"\0" * (-len(data) % 4)
    total = 12 + 8 + len(text) + 8 + len(data)
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(text), b"JSON"))
        f.write(text)
        f.write(struct.pack("<I4s", len(data), b"BIN\0"))
        f.write(data)


def data_uri(data):
    return "data:application/octet-stream;base64," + base64.b64encode(bytes(data)).decode("ascii")


# ---------------------------------------------------------------------------------------------
# The Cornell box
# ---------------------------------------------------------------------------------------------

# Geometry: Cornell University Program of Computer Graphics, "Cornell Box Data"
# (graphics.cornell.edu/online/box/data.html), in millimetres, each surface a quadrilateral
# listed as the page lists it. The page gives the light at y = 548.8, in the plane of the
# ceiling; here it hangs 0.1 mm lower (LIGHT_DROP_MM) so the two surfaces never share a plane
# (coplanar surfaces make the first hit ambiguous). The 0.1 mm drop changes the light's distance
# to the floor by 0.02 %.
LIGHT_DROP_MM = 0.1
CORNELL_MM = {
    "floor": [
        [(552.8, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 559.2), (549.6, 0.0, 559.2)],
    ],
    "light": [
        [
            (343.0, 548.8 - LIGHT_DROP_MM, 227.0),
            (343.0, 548.8 - LIGHT_DROP_MM, 332.0),
            (213.0, 548.8 - LIGHT_DROP_MM, 332.0),
            (213.0, 548.8 - LIGHT_DROP_MM, 227.0),
        ],
    ],
    "ceiling": [
        [(556.0, 548.8, 0.0), (556.0, 548.8, 559.2), (0.0, 548.8, 559.2), (0.0, 548.8, 0.0)],
    ],
    "back_wall": [
        [(549.6, 0.0, 559.2), (0.0, 0.0, 559.2), (0.0, 548.8, 559.2), (556.0, 548.8, 559.2)],
    ],
    "right_wall": [
        [(0.0, 0.0, 559.2), (0.0, 0.0, 0.0), (0.0, 548.8, 0.0), (0.0, 548.8, 559.2)],
    ],
    "left_wall": [
        [(552.8, 0.0, 0.0), (549.6, 0.0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0.0)],
    ],
    "short_block": [
        [(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
        [(290.0, 0.0, 114.0), (290.0, 165.0, 114.0), (240.0, 165.0, 272.0), (240.0, 0.0, 272.0)],
        [(130.0, 0.0, 65.0), (130.0, 165.0, 65.0), (290.0, 165.0, 114.0), (290.0, 0.0, 114.0)],
        [(82.0, 0.0, 225.0), (82.0, 165.0, 225.0), (130.0, 165.0, 65.0), (130.0, 0.0, 65.0)],
        [(240.0, 0.0, 272.0), (240.0, 165.0, 272.0), (82.0, 165.0, 225.0), (82.0, 0.0, 225.0)],
    ],
    "tall_block": [
        [(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
        [(423.0, 0.0, 247.0), (423.0, 330.0, 247.0), (472.0, 330.0, 406.0), (472.0, 0.0, 406.0)],
        [(472.0, 0.0, 406.0), (472.0, 330.0, 406.0), (314.0, 330.0, 456.0), (314.0, 0.0, 456.0)],
        [(314.0, 0.0, 456.0), (314.0, 330.0, 456.0), (265.0, 330.0, 296.0), (265.0, 0.0, 296.0)],
        [(265.0, 0.0, 296.0), (265.0, 330.0, 296.0), (423.0, 330.0, 247.0), (423.0, 0.0, 247.0)],
    ],
}

# The camera, from the same page: position (278, 273, -800) mm, direction (0, 0, 1), up (0, 1, 0),
# focal length 35 mm, film 25 mm x 25 mm, so the vertical field of view is 2 atan(12.5 / 35).
CAMERA_POSITION_MM = (278.0, 273.0, -800.0)
CAMERA_YFOV = 2.0 * math.atan(12.5 / 35.0)

# RGB values. The Cornell page gives reflectance and emission spectra, not RGB; these are the
# widely used RGB conversions from Benedikt Bitterli's "Rendering Resources" cornell-box scene
# (Tungsten format; the same numbers appear in pbrt-v4 and Mitsuba conversions of it):
# white 0.725 0.71 0.68, red 0.63 0.065 0.05, green 0.14 0.45 0.091, light radiance 17 12 4.
WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LIGHT_RADIANCE = (17.0, 12.0, 4.0)
# The light's own diffuse reflectance: 0.78 (grey), as in Mitsuba's "cbox" scene.
LIGHT_ALBEDO = (0.78, 0.78, 0.78)


def quads_to_mesh(quads):
    """Each quad (p0, p1, p2, p3) becomes triangles (p0, p1, p2) and (p0, p2, p3), keeping the
    winding of the listing; vertices are converted from millimetres to metres."""
    points, triangles = [], []
    for quad in quads:
        base = len(points)
        points.extend(tuple(c / 1000.0 for c in p) for p in quad)
        triangles.append((base, base + 1, base + 2))
        triangles.append((base, base + 2, base + 3))
    return points, triangles


# The room's centre (mm / 1000): every wall, the floor and the ceiling face it.
CORNELL_CENTRE = (0.278, 0.2744, 0.2796)


def check_winding(name, points, triangles, centre=CORNELL_CENTRE):
    """The listing winds every surface so that its front face looks into the room (walls,
    floor, ceiling, light) or out of the block (blocks). Check it, since a light emits from its
    front face only."""
    for t in triangles:
        n = face_normal(points, t)
        p0 = points[t[0]]
        to_centre = sub(centre, p0)
        if name.endswith("block"):
            # The block faces' fronts point away from the block's own centre.
            block = [p for p in points]
            c = tuple(sum(p[i] for p in block) / len(block) for i in range(3))
            assert dot(n, sub(p0, c)) > 0.0, (name, t)
        else:
            assert dot(n, to_centre) > 0.0, (name, t)


def cornell_camera(b):
    # glTF cameras look down their local -Z with +Y up; the Cornell camera looks down world +Z
    # with +Y up: a half turn about Y, the unit quaternion (x, y, z, w) = (0, 1, 0, 0). Its right
    # (local +X) is then world -X, so the red wall (x = 0.55 m) is on the left, as in the photos.
    return b.camera(
        "cornell camera",
        CAMERA_YFOV,
        1.0,
        tuple(c / 1000.0 for c in CAMERA_POSITION_MM),
        (0.0, 1.0, 0.0, 0.0),
    )


def cornell_colours(b):
    """The Cornell box's white, red and green materials, added to `b` in that order."""
    return b.material("white", WHITE), b.material("red", RED), b.material("green", GREEN)


def room_surfaces(white, red, green):
    """The Cornell box's room and blocks (every surface but the light), with the materials the
    published data gives them."""
    return [
        ("floor", white),
        ("ceiling", white),
        ("back_wall", white),
        ("right_wall", green),
        ("left_wall", red),
        ("short_block", white),
        ("tall_block", white),
    ]


def add_cornell_surfaces(b, surfaces):
    """Adds each (name, material[, uv mapping]) of `surfaces` as a mesh of CORNELL_MM's quads,
    after checking their winding; the mapping, if any, gives the mesh's TEXCOORD_0."""
    for name, material, *mapping in surfaces:
        points, triangles = quads_to_mesh(CORNELL_MM[name])
        check_winding(name, points, triangles)
        uvs = mapping[0](points) if mapping and mapping[0] else None
        b.mesh(name, points, triangles, material, component_type=5123, uvs=uvs)


def cornell_box():
    b = Builder()
    white, red, green = cornell_colours(b)
    # Single-sided: the light emits from its front face only, downwards into the box.
    light = b.material("light", LIGHT_ALBEDO, emission=LIGHT_RADIANCE, double_sided=False)
    add_cornell_surfaces(b, room_surfaces(white, red, green) + [("light", light)])
    cornell_camera(b)
    write_scene(b, "cornell-box", "Cornell Box Data (Cornell University PCG), metres")


# The Cornell box with its camera dollied 10 cm to the right (world -X: the camera's right is
# world -X, see cornell_camera) over 1 s: a walkthrough for --frames and --shared-cache.
DOLLY_M = 0.1


def cornell_walk(name, description, shift):
    # The Cornell box whose camera a LINEAR translation channel moves by `shift` (metres,
    # world axes) over 1 s.
    b = Builder()
    white, red, green = cornell_colours(b)
    light = b.material("light", LIGHT_ALBEDO, emission=LIGHT_RADIANCE, double_sided=False)
    add_cornell_surfaces(b, room_surfaces(white, red, green) + [("light", light)])
    camera = cornell_camera(b)
    start = [c / 1000.0 for c in CAMERA_POSITION_MM]
    end = [s + d for s, d in zip(start, shift)]
    b.animate_translation(camera, [0.0, 1.0], [start, end])
    write_scene(b, name, description)


def cornell_dolly():
    cornell_walk("cornell-dolly", "the Cornell box, its camera dollied 10 cm right over 1 s",
                 [-DOLLY_M, 0.0, 0.0])


# The push-in: the camera moves PUSH_M towards the back wall over 1 s, so the last frames see the
# wall and the blocks at about half the first frame's distance (a shared cache's records must
# then be as fine as the nearest key frame needs).
PUSH_M = 0.6


def cornell_push():
    cornell_walk("cornell-push", "the Cornell box, its camera pushed 60 cm in over 1 s",
                 [0.0, 0.0, PUSH_M])


# ---------------------------------------------------------------------------------------------
# Variations on the Cornell box
# ---------------------------------------------------------------------------------------------

# The room lit only indirectly. The Cornell box without its ceiling light; instead an uplight,
# a 300 mm x 300 mm panel, hangs INDIRECT_GAP_MM below the ceiling with its emitting face turned
# UP: the ceiling above it is the only surface the light reaches directly, and everything else
# the camera sees is lit by bounced light (the case where an irradiance cache does all the work
# and a path tracer is noisiest). The panel is large and 100 mm down so that the lit patch of
# ceiling is broad: a small panel close to the ceiling (the Cornell light's footprint 19 mm
# under it was tried) makes a small, very bright patch that a bounce from a wall rarely finds,
# and the path tracer's relMSE at 64 spp (64 x 64, against 1024 spp) was 8x this room's.
#
# The panel is a thin closed fixture:
# - the emitter, a single-sided quad at y = INDIRECT_PANEL_Y_MM facing +Y;
# - its underside, a non-emissive quad INDIRECT_THICKNESS_MM lower facing -Y, with the light's
#   albedo, so the camera sees a dark panel instead of looking through the emitter's back; the
#   two never share a plane (coplanar surfaces make the first hit ambiguous);
# - a lip of INDIRECT_LIP_MM around the emitter (four vertical quads from the underside up),
#   because without it the top INDIRECT_GAP_MM of every wall stands above the emitter's plane
#   and sees it at a grazing angle: a thin directly lit strip under the ceiling. The lip is
#   high enough to block every such ray (asserted in indirect_room()).
# The underside and the lip (the housing) stand INDIRECT_MARGIN_MM outside the emitter's edges:
# with the emitter's edges on the lip's planes, a shadow ray to a light sample on the very
# edge ends a hair before the lip and slips under it (measured: a few grazing samples of
# direct light on the far ceiling in a 512 x 512 direct-only render).
INDIRECT_PANEL_Y_MM = 448.8
INDIRECT_THICKNESS_MM = 1.0
INDIRECT_LIP_MM = 80.0
INDIRECT_MARGIN_MM = 1.0
INDIRECT_GAP_MM = 548.8 - INDIRECT_PANEL_Y_MM
# The panel's footprint (x, z in mm), centred under the ceiling.
PANEL_X_MM = (128.0, 428.0)
PANEL_Z_MM = (130.0, 430.0)
# The emitted radiance: the Cornell light's colour times INDIRECT_GAIN (10.2 7.2 2.4), so that
# the room is as bright as the Cornell box: image mean radiance 0.195 0.125 0.035 against the
# Cornell box's 0.198 0.129 0.037 (irr's default render at 256 x 256).
INDIRECT_GAIN = 0.6
INDIRECT_RADIANCE = tuple(INDIRECT_GAIN * c for c in LIGHT_RADIANCE)


def indirect_room():
    b = Builder()
    white, red, green = cornell_colours(b)
    # Single-sided: the emitter's front face looks up at the ceiling; its back emits nothing.
    light = b.material("light", LIGHT_ALBEDO, emission=INDIRECT_RADIANCE, double_sided=False)
    housing = b.material("light housing", LIGHT_ALBEDO)
    add_cornell_surfaces(b, room_surfaces(white, red, green))

    (x0, x1), (z0, z1) = PANEL_X_MM, PANEL_Z_MM
    top = INDIRECT_PANEL_Y_MM
    bottom = top - INDIRECT_THICKNESS_MM
    lip = top + INDIRECT_LIP_MM
    # Wound so that (p1 - p0) x (p2 - p0) points up: the emitter's front face is +Y.
    emitter = [(x1, top, z0), (x0, top, z0), (x0, top, z1), (x1, top, z1)]
    # The housing's footprint, INDIRECT_MARGIN_MM larger on every side.
    m = INDIRECT_MARGIN_MM
    hx0, hx1, hz0, hz1 = x0 - m, x1 + m, z0 - m, z1 + m
    # The Cornell light's own winding, facing down.
    underside = [(hx1, bottom, hz0), (hx1, bottom, hz1), (hx0, bottom, hz1), (hx0, bottom, hz0)]
    # Each lip quad runs from the underside's edge up to `lip`, its front face outwards.
    corners = [(hx0, hz0), (hx1, hz0), (hx1, hz1), (hx0, hz1)]
    lips = []
    for (ax, az), (bx, bz) in zip(corners, corners[1:] + corners[:1]):
        lips.append([(ax, bottom, az), (ax, lip, az), (bx, lip, bz), (bx, bottom, bz)])
    points, triangles = quads_to_mesh([emitter])
    for t in triangles:
        assert face_normal(points, t)[1] > 0.0  # the emitter faces up
    b.mesh("light", points, triangles, light, component_type=5121)
    points, triangles = quads_to_mesh([underside] + lips)
    panel_centre = ((hx0 + hx1) / 2000.0, top / 1000.0, (hz0 + hz1) / 2000.0)
    for k, t in enumerate(triangles):
        n = face_normal(points, t)
        if k < 2:
            assert n[1] < 0.0  # the underside faces down
        else:
            assert dot(n, sub(points[t[0]], panel_centre)) > 0.0  # the lip faces out
    b.mesh("light housing", points, triangles, housing, component_type=5121)

    # No wall sees the emitter over the lip. A ray from an emitter point to a wall point above
    # the emitter's plane (at most INDIRECT_GAP_MM above it) leaves the housing's footprint
    # after a horizontal run d <= the footprint's diagonal and reaches the wall after a further
    # run D >= the footprint's smallest horizontal distance to a wall (the left wall's smallest
    # x is 549.6 mm; the front is open and the blocks are far below), so it rises at most
    # gap * d / (d + D) by the time it crosses the lip, which must stand higher than that.
    d_max = math.hypot(hx1 - hx0, hz1 - hz0)
    d_wall = min(hx0 - 0.0, 549.6 - hx1, 559.2 - hz1)
    assert INDIRECT_LIP_MM > INDIRECT_GAP_MM * d_max / (d_max + d_wall)
    assert lip < 548.8  # and the light still reaches the ceiling

    cornell_camera(b)
    radiance = " ".join("%g" % c for c in INDIRECT_RADIANCE)
    write_scene(
        b,
        "indirect-room",
        "Cornell box lit only indirectly: a %g x %g mm panel %g mm under the ceiling emitting "
        "%s upwards, metres" % (x1 - x0, z1 - z0, INDIRECT_GAP_MM, radiance),
    )


# The textured room: the Cornell box with its ceiling light (direct light, as in cornell-box),
# but with base-colour textures carrying detail finer than the lighting: where a denoiser
# blurs, and where an irradiance cache must multiply the texture's albedo at the shading
# point rather than interpolate it. Each texture is mapped by a planar projection in metres
# (texels stay square on every surface) and repeats (wrap REPEAT):
# - floor: basket-weave parquet, 128 x 128 texels per TEX_FLOOR_M metres: 32-texel squares of
#   two 16-texel planks (3.1 cm, about 4-10 pixels on a 256 x 256 image, depending on depth
#   and foreshortening), 1-texel seams, per-plank shades and per-row grain; LINEAR filter;
# - back wall: 128 x 128 texels over the whole wall (4.3 mm a texel, about 1.15 pixels at
#   256 x 256): two rows of 5 x 7 glyphs with 2-texel strokes ("IRRADIANCE" / "CACHE TEST"),
#   then bands of vertical stripes 8, 4 and 2 texels wide (about 9, 4.6 and 2.3 pixels),
#   horizontal stripes 2 texels wide and a 4-texel checker at the bottom; LINEAR filter;
# - both blocks: a two-colour checker of 8-texel squares, 16 x 16 texels per TEX_BLOCK_M
#   (2.5 cm squares, about 6-10 pixels); NEAREST filter, so both of glTF's filters are used;
# - side walls, ceiling and light: plain, as in the Cornell box.
# The images are PNG files next to the .gltf (irr reads images from a file, a data: URI or a
# bufferView; files let anyone open the textures in an image viewer and see them change in a
# diff). Every texel is computed with integers only, and the PNGs hold stored (uncompressed)
# deflate blocks, so the bytes do not depend on the platform's libm or zlib version; the three
# files take about 100 KB. Texel values are sRGB; no channel exceeds TEX_MAX_ALBEDO linear
# (asserted; the brightest, the wall's paper at sRGB 222, is 0.73, the Cornell white's 0.725).
TEX_FLOOR_M = 0.25
TEX_BLOCK_M = 0.05
TEX_MAX_ALBEDO = 0.8

# 5 x 7 glyphs, one string per row, "#" inked.
GLYPHS = {
    "A": [".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"],
    "C": [".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."],
    "D": ["####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####."],
    "E": ["#####", "#....", "#....", "####.", "#....", "#....", "#####"],
    "H": ["#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"],
    "I": [".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."],
    "N": ["#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"],
    "R": ["####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"],
    "S": [".####", "#....", "#....", ".###.", "....#", "....#", "####."],
    "T": ["#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."],
    " ": ["....."] * 7,
}


def srgb_to_linear(c):
    """An 8-bit sRGB value to linear (IEC 61966-2-1), for the albedo check only."""
    c = c / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def hash32(*values):
    """A small integer hash (multiply-xorshift), for deterministic per-plank variation."""
    h = 0x811C9DC5
    for v in values:
        h = ((h ^ (v & 0xFFFFFFFF)) * 0x01000193) & 0xFFFFFFFF
        h ^= h >> 15
        h = (h * 0x2C1B3C6D) & 0xFFFFFFFF
        h ^= h >> 12
    return h


def shade(rgb, percent):
    return tuple(c * percent // 100 for c in rgb)


def floor_texture():
    """Basket-weave parquet, 128 x 128: 4 x 4 squares of 32 texels, each two planks wide, the
    planks running along u in one square and along v in the next."""
    n, square, plank = 128, 32, 16
    woods = [(176, 124, 78), (160, 110, 66), (190, 140, 92), (168, 118, 72)]
    seam = (92, 62, 40)
    rows = []
    for y in range(n):
        row = []
        for x in range(n):
            sx, sy = x // square, y // square
            along_u = (sx + sy) % 2 == 0
            # across: position across the planks; along: position along them.
            across, along = (y % square, x % square) if along_u else (x % square, y % square)
            k = across // plank
            wood = woods[hash32(sx, sy, k) % len(woods)]
            if across % plank == 0 or along == 0:
                row.append(seam)
                continue
            # Grain: each line of texels along the plank gets its own darkening (0-15 %),
            # and a few short darker streaks break it up along the plank.
            grain = hash32(sx, sy, k, across) % 4 * 5
            streak = 10 if hash32(sx, sy, k, across, along // 6) % 7 == 0 else 0
            row.append(shade(wood, 100 - grain - streak))
        rows.append(row)
    return n, n, rows


def back_wall_texture():
    """128 x 128 over the whole back wall, top row at the ceiling: glyph rows, then stripes."""
    n = 128
    paper = (222, 214, 196)
    ink = (40, 48, 72)
    rows = [[paper] * n for _ in range(n)]

    def fill(x, y, w, h):
        for j in range(y, min(y + h, n)):
            for i in range(x, min(x + w, n)):
                rows[j][i] = ink

    # Two lines of 10 glyphs, each glyph cell 2 x 2 texels (10 x 14), 12 texels apart.
    cell, pitch = 2, 12
    for line, text in enumerate(["IRRADIANCE", "CACHE TEST"]):
        y0 = 6 + line * 18
        x0 = (n - (pitch * len(text) - 2)) // 2
        for c, ch in enumerate(text):
            for gy, bits in enumerate(GLYPHS[ch]):
                for gx, bit in enumerate(bits):
                    if bit == "#":
                        fill(x0 + c * pitch + gx * cell, y0 + gy * cell, cell, cell)
    # Bands 12 texels tall, 4 apart: vertical stripes 8, 4 and 2 texels wide, then
    # horizontal stripes 2 texels wide; a 4-texel checker fills the rest.
    y = 46
    for width in (8, 4, 2):
        for x in range(0, n, 2 * width):
            fill(x, y, width, 12)
        y += 16
    for j in range(y, y + 12, 4):
        fill(0, j, n, 2)
    y += 16
    for j in range(y, n):
        for i in range(n):
            if (i // 4 + j // 4) % 2 == 0:
                rows[j][i] = ink
    return n, n, rows


def block_texture():
    """A 16 x 16 checker of 8-texel squares."""
    light, dark = (214, 212, 204), (112, 122, 146)
    rows = [[light if (x // 8 + y // 8) % 2 == 0 else dark for x in range(16)] for y in range(16)]
    return 16, 16, rows


def png_scanlines(rows):
    """The PNG's filtered image data: each row of texels (tuples of 8-bit channels) behind a
    filter-type byte 0 (None)."""
    return b"".join(b"\0" + bytes(c for texel in row for c in texel) for row in rows)


def png_encode(width, height, rows, colour_type, channels):
    """An 8-bit PNG of colour type `colour_type` (`channels` channels a texel) whose zlib stream
    holds stored (uncompressed) deflate blocks: the same bytes from any zlib (compressed output
    may differ between zlib versions and forks)."""
    raw = png_scanlines(rows)
    assert len(raw) == height * (1 + channels * width)
    stream = bytearray(b"\x78\x01")  # deflate, 32 K window, no dictionary, FCHECK
    for start in range(0, len(raw), 65535):
        block = raw[start : start + 65535]
        final = 1 if start + 65535 >= len(raw) else 0
        stream += struct.pack("<BHH", final, len(block), len(block) ^ 0xFFFF) + block
    stream += struct.pack(">I", zlib.adler32(raw))

    def chunk(kind, body):
        crc = struct.pack(">I", zlib.crc32(kind + body))
        return struct.pack(">I", len(body)) + kind + body + crc

    ihdr = struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)
    signature = b"\x89PNG\r\n\x1a\n"
    return signature + chunk(b"IHDR", ihdr) + chunk(b"IDAT", bytes(stream)) + chunk(b"IEND", b"")


def png_bytes(width, height, rows):
    """An 8-bit RGB PNG (colour type 2, truecolour), see `png_encode`."""
    return png_encode(width, height, rows, 2, 3)


def png_rgba_bytes(width, height, rows):
    """An 8-bit RGBA PNG (colour type 6, truecolour with alpha, not premultiplied), see
    `png_encode`."""
    return png_encode(width, height, rows, 6, 4)


def check_image(name, image, channels):
    width, height, rows = image
    assert len(rows) == height and all(len(r) == width for r in rows), name
    assert all(len(t) == channels and all(0 <= c <= 255 for c in t) for r in rows for t in r), name


def check_albedo(name, rows):
    """Colour texels (sRGB; the alpha channel, if any, aside) stay at most TEX_MAX_ALBEDO."""
    brightest = max(c for row in rows for texel in row for c in texel[:3])
    assert srgb_to_linear(brightest) <= TEX_MAX_ALBEDO, (name, brightest)


def write_png(name, data, rows):
    """Writes PNG bytes `data`, encoding `rows`, next to this script, after checking that they
    decode back to the texels: the IDAT payload lies after the signature (8 bytes), IHDR
    (4 + 4 + 13 + 4) and IDAT's length and type (8), and before IDAT's CRC (4) and IEND (12)."""
    idat = data[8 + 25 + 8 : -4 - 12]
    assert zlib.decompress(idat) == png_scanlines(rows)
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def write_texture(name, image):
    """A base colour texture: RGB, sRGB, albedo at most TEX_MAX_ALBEDO."""
    check_image(name, image, 3)
    width, height, rows = image
    check_albedo(name, rows)
    write_png(name, png_bytes(width, height, rows), rows)


def write_rgba_texture(name, image):
    """A base colour texture with coverage: RGB as `write_texture`'s, alpha linear."""
    check_image(name, image, 4)
    width, height, rows = image
    check_albedo(name, rows)
    write_png(name, png_rgba_bytes(width, height, rows), rows)


X_AXIS, Z_AXIS, DOWN = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)


def planar_uvs(points, origin, u_axis, v_axis, size):
    """(u, v) = the offsets from `origin` along the unit axes, in units of `size` metres."""
    return [
        (dot(sub(p, origin), u_axis) / size, dot(sub(p, origin), v_axis) / size) for p in points
    ]


def block_uvs(points):
    """Each block quad's own planar map: the top in x and z, a side along its bottom edge
    (listed p0 -> p3) and down."""
    uvs = []
    for q in range(0, len(points), 4):
        quad = points[q : q + 4]
        if all(abs(p[1] - quad[0][1]) < 1e-9 for p in quad):
            uvs += planar_uvs(quad, (0.0, 0.0, 0.0), X_AXIS, Z_AXIS, TEX_BLOCK_M)
        else:
            u_axis = normalise(sub(quad[3], quad[0]))
            assert abs(u_axis[1]) < 1e-9, quad  # the bottom edge is horizontal
            uvs += planar_uvs(quad, quad[0], u_axis, DOWN, TEX_BLOCK_M)
    return uvs


def textured_room():
    b = Builder()
    floor_tex = b.texture("parquet", "textured-room-floor.png", 9729)  # LINEAR
    wall_tex = b.texture("glyphs and stripes", "textured-room-back-wall.png", 9729)  # LINEAR
    block_tex = b.texture("checker", "textured-room-blocks.png", 9728)  # NEAREST
    write_texture("textured-room-floor.png", floor_texture())
    write_texture("textured-room-back-wall.png", back_wall_texture())
    write_texture("textured-room-blocks.png", block_texture())
    # A textured material's baseColorFactor is white: the albedo is the texture's colour.
    white, red, green = cornell_colours(b)
    parquet = b.material("parquet", (1.0, 1.0, 1.0), texture=floor_tex)
    poster = b.material("glyphs and stripes", (1.0, 1.0, 1.0), texture=wall_tex)
    checker = b.material("checker", (1.0, 1.0, 1.0), texture=block_tex)
    light = b.material("light", LIGHT_ALBEDO, emission=LIGHT_RADIANCE, double_sided=False)
    # The back wall's map: u from the red wall's side (x = 0.556 m, on the camera's left)
    # towards x = 0, v down from the ceiling, one texture over 0.556 m, so text reads
    # left to right, upright.
    wall_size = 0.556
    wall_corner, minus_x = (wall_size, 0.5488, 0.0), (-1.0, 0.0, 0.0)
    surfaces = [
        ("floor", parquet, lambda p: planar_uvs(p, (0.0, 0.0, 0.0), X_AXIS, Z_AXIS, TEX_FLOOR_M)),
        ("ceiling", white, None),
        ("back_wall", poster, lambda p: planar_uvs(p, wall_corner, minus_x, DOWN, wall_size)),
        ("right_wall", green, None),
        ("left_wall", red, None),
        ("short_block", checker, block_uvs),
        ("tall_block", checker, block_uvs),
        ("light", light, None),
    ]
    add_cornell_surfaces(b, surfaces)
    cornell_camera(b)
    write_scene(
        b,
        "textured-room",
        "Cornell box with base-colour textures (parquet, glyphs, checker), metres",
    )


# ---------------------------------------------------------------------------------------------
# The glossy room: the Cornell box with users' materials
# ---------------------------------------------------------------------------------------------

# The specification's metallic-roughness model on the Cornell box: a rough gold metal tall
# block (base colour: gold's F0 in linear sRGB, as the glTF sample models use it), a glossy blue
# plastic short block (a dielectric: white highlights over a blue base), a rough dielectric floor (specular 1, the glTF default) whose reflection of
# the blocks and the light is visibly blurred, the textured room's poster on the back wall as a
# semi-gloss dielectric, and the Cornell colours as matte dielectrics (roughness 1 with the
# default specular layer). The ceiling light is the Cornell box's.
GOLD = (1.0, 0.766, 0.336)
BLUE = (0.05, 0.15, 0.5)


def glossy_room_surfaces(b, floor, floor_uvs=None):
    """The glossy room's surfaces, as `add_cornell_surfaces` takes them, with the floor's
    material `floor` (and its uv mapping, if any); adds the other materials and the poster's
    texture to `b`."""
    wall_tex = b.texture("glyphs and stripes", "textured-room-back-wall.png", 9729)  # LINEAR
    ceiling = b.glossy_material("ceiling, matte", WHITE, 0.0, 1.0)
    red = b.glossy_material("red, matte", RED, 0.0, 1.0)
    green = b.glossy_material("green, matte", GREEN, 0.0, 1.0)
    poster = b.glossy_material("poster, semi-gloss", (1.0, 1.0, 1.0), 0.0, 0.5, texture=wall_tex)
    gold = b.glossy_material("tall block, rough gold", GOLD, 1.0, 0.3)
    plastic = b.glossy_material("short block, glossy plastic", BLUE, 0.0, 0.2)
    light = b.material("light", LIGHT_ALBEDO, emission=LIGHT_RADIANCE, double_sided=False)
    wall_size = 0.556
    wall_corner, minus_x = (wall_size, 0.5488, 0.0), (-1.0, 0.0, 0.0)
    return [
        ("floor", floor, floor_uvs),
        ("ceiling", ceiling, None),
        ("back_wall", poster, lambda p: planar_uvs(p, wall_corner, minus_x, DOWN, wall_size)),
        ("right_wall", green, None),
        ("left_wall", red, None),
        ("short_block", plastic, None),
        ("tall_block", gold, None),
        ("light", light, None),
    ]


def glossy_floor(b, normal_texture=None):
    """The glossy room's floor, a rough dielectric."""
    name = "floor, rough dielectric" + (", bevelled tiles" if normal_texture is not None else "")
    return b.glossy_material(name, WHITE, 0.0, 0.35, normal_texture=normal_texture)


def glossy_room():
    b = Builder()
    add_cornell_surfaces(b, glossy_room_surfaces(b, glossy_floor(b)))
    cornell_camera(b)
    write_scene(b, "glossy-room", "Cornell box with glTF metallic-roughness materials, metres")


# The glossy room with a rough metal floor (roughness 0.8): a glossy lobe wide enough for
# low-order spherical harmonics over a large part of the image, where radiance caching applies.
METAL_FLOOR = (0.95, 0.93, 0.88)


def metal_floor_room():
    b = Builder()
    floor = b.glossy_material("floor, rough metal", METAL_FLOOR, 1.0, 0.8)
    add_cornell_surfaces(b, glossy_room_surfaces(b, floor))
    cornell_camera(b)
    write_scene(b, "metal-floor-room", "the glossy room with a rough metal floor, metres")


# ---------------------------------------------------------------------------------------------
# The detail room: the glossy room with a normal-mapped floor and a cut-out lattice
# ---------------------------------------------------------------------------------------------

# The glossy room (same geometry, camera, light and materials, so the two compare directly)
# with two kinds of surface detail finer than its geometry:
# - the floor's normal texture (glTF normalTexture, scale 1; no TANGENT, so the renderer makes
#   MikkTSpace tangents from the floor's planar uvs): square tiles DETAIL_TILE texels wide,
#   2 x 2 to a 128 x 128 texture that repeats every DETAIL_TILE_M metres (about 4 x 4 repeats,
#   8 x 8 tiles of 7 cm over the floor), each a flat top with bevelled edges sloping down
#   (slope DETAIL_DEPTH / DETAIL_BEVEL) to a flat grout line, so the rough floor's reflection
#   of the light and the blocks breaks up along the tiles' edges; LINEAR filter;
# - a lattice, a free-standing wooden trellis panel: one double-sided quad, standing on the
#   floor parallel to the back wall and LATTICE_GAP_MM in front of it, beside the tall block
#   on the camera's right (behind the short block, which hides its bottom few cm), cut out
#   by the alpha channel of its RGBA base colour texture (alphaMode MASK, alphaCutoff 0.5): a
#   grid of square holes between bars. The ceiling light lights its front and casts the
#   grid's shadow on the back wall behind it (and on the strip of floor between), shifted
#   down by a few cm and softened by the light's size; NEAREST filter, so the holes are
#   exactly the transparent texels.
# Both images are computed without libm (integers, IEEE arithmetic and square roots only) and
# stored as uncompressed PNGs, as the textured room's.
DETAIL_TILE_M = 0.139  # metres per repeat of the floor's normal texture
DETAIL_N = 128  # the normal texture's width and height, texels
DETAIL_TILE = 64  # a tile's pitch, texels (1.09 mm a texel)
DETAIL_GROUT = 1  # half the grout line's width, texels
DETAIL_BEVEL = 6  # the bevel's run, texels
DETAIL_DEPTH = 3  # the bevel's rise (top above grout), texels: a slope of 1/2 (26.6 degrees)

# The lattice, in millimetres as the Cornell data (LATTICE_TEXEL_MM a texel): a frame of
# LATTICE_FRAME texels around LATTICE_COLUMNS x LATTICE_ROWS square holes of LATTICE_HOLE
# texels, between bars of LATTICE_BAR texels.
LATTICE_TEXEL_MM = 2.5
LATTICE_FRAME, LATTICE_HOLE, LATTICE_BAR = 6, 10, 6
LATTICE_COLUMNS, LATTICE_ROWS = 5, 9
LATTICE_GAP_MM = 25.0  # in front of the back wall (z = 559.2 mm)
LATTICE_RIGHT_X_MM = 35.0  # its edge on the camera's right, 35 mm from the green wall (x = 0)


def lattice_size():
    """The lattice texture's width and height, texels."""
    side = lambda k: 2 * LATTICE_FRAME + k * LATTICE_HOLE + (k - 1) * LATTICE_BAR
    return side(LATTICE_COLUMNS), side(LATTICE_ROWS)


def tile_height(col, row):
    """The floor tiles' height field at texel (col, row)'s centre, in units of
    1 / (2 DETAIL_BEVEL) texel (an integer): 0 on the grout, DETAIL_DEPTH texels on a tile's top,
    rising linearly over DETAIL_BEVEL texels with the distance to the nearest tile edge.
    Periodic in DETAIL_TILE, so the texture repeats seamlessly."""

    def edge(i):  # twice the distance from texel i's centre to the nearest tile edge
        s = 2 * (i % DETAIL_TILE) + 1
        return min(s, 2 * DETAIL_TILE - s)

    run = min(max(min(edge(col), edge(row)) - 2 * DETAIL_GROUT, 0), 2 * DETAIL_BEVEL)
    return run * DETAIL_DEPTH


def encode_normal(n):
    """A unit tangent-space normal as 8-bit RGB (glTF 2.0 §3.9.3): round(255 (n + 1) / 2)."""
    return tuple(int(math.floor(255.0 * (c + 1.0) / 2.0 + 0.5)) for c in n)


def decode_normal(rgb):
    return tuple(c / 255.0 * 2.0 - 1.0 for c in rgb)


def tile_normal_texture():
    """DETAIL_N x DETAIL_N tangent-space normals of `tile_height`, by central differences.

    glTF's tangent space: +X along increasing u (to the right in the image), +Y up the image
    (towards decreasing v: v, like the row index, grows down), +Z out of the surface. For a
    height field h(x, y) over that frame, the surface (x, y, h) has tangents (1, 0, h_x) and
    (0, 1, h_y), and normal (1, 0, h_x) x (0, 1, h_y) = (-h_x, -h_y, 1). With x = col and
    y = -row: n ~ (-dh/dcol, +dh/drow, 1)."""
    n = DETAIL_N
    # The central differences are (h(i + 1) - h(i - 1)) / 2 texels; with h in units of
    # 1 / (2 DETAIL_BEVEL) texel, the vector below is n times 4 DETAIL_BEVEL, all integers.
    rows = []
    for row in range(n):
        texels = []
        for col in range(n):
            dh_dcol = tile_height((col + 1) % n, row) - tile_height((col - 1) % n, row)
            dh_drow = tile_height(col, (row + 1) % n) - tile_height(col, (row - 1) % n)
            v = (-dh_dcol, dh_drow, 4 * DETAIL_BEVEL)
            length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            texels.append(encode_normal(tuple(c / length for c in v)))
        rows.append(texels)
    return n, n, rows


def check_tile_normals(image):
    """The encoding's signs, checked on the height field itself (not on the formula above).
    - On a tile's right-hand bevel (row 32 across the middle, col 60, 3.5 texels from the edge
      at col 64) the height decreases to the right, so the surface faces right: n_x > 0, red
      > 128.
    - On a tile's bottom bevel (col 32, row 60) the height rises towards the top of the image
      (decreasing row). A surface sloping up towards the top of the image leans back: its
      normal tilts away from the rise, towards the bottom of the image, which is -Y in glTF's
      tangent space (+Y is up the image): n_y < 0, green < 128.
    - The left and top bevels mirror these (red < 128, green > 128); a tile's top
      is flat, (128, 128, 255). (The grout, 2 texels wide, tilts slightly: its central
      differences reach the bevel's first texel.)"""
    _, _, rows = image
    assert tile_height(59, 32) > tile_height(61, 32)  # decreasing to the right
    r, g, b = rows[32][60]
    assert r > 128 and g == 128 and b < 255, (r, g, b)
    assert tile_height(32, 59) > tile_height(32, 61)  # rising towards the top (smaller row)
    r, g, b = rows[60][32]
    assert g < 128 and r == 128 and b < 255, (r, g, b)
    assert rows[32][4][0] < 128 and rows[4][32][1] > 128
    assert rows[32][32] == rows[10][50] == (128, 128, 255)
    # The bevel's exact normal, (1, 0, 2) / sqrt(5) for a slope of 1/2, and its mirror images.
    s = DETAIL_DEPTH / DETAIL_BEVEL
    k = 1.0 / math.sqrt(1.0 + s * s)
    assert rows[32][60] == encode_normal((s * k, 0.0, k)) == (185, 128, 242)
    assert rows[60][32] == encode_normal((0.0, -s * k, k)) == (128, 70, 242)


def write_normal_texture(name, image):
    """A normal texture: data (linear RGB), not albedo, so no albedo check; instead every texel
    must decode to a nearly unit vector facing out of the surface."""
    check_image(name, image, 3)
    width, height, rows = image
    for row in rows:
        for texel in row:
            n = decode_normal(texel)
            assert n[2] > 0.0 and abs(math.sqrt(dot(n, n)) - 1.0) < 0.01, (name, texel)
    write_png(name, png_bytes(width, height, rows), rows)


def lattice_texture():
    """The lattice: RGBA, bars and frame opaque wood (per-bar shade and grain), holes alpha 0
    (their colour the wood's, so no filter could bleed a dark fringe in)."""
    width, height = lattice_size()
    pitch = LATTICE_HOLE + LATTICE_BAR
    wood = (150, 98, 56)

    def in_hole(i, count):  # whether texel i (along an axis with `count` holes) is in one
        j = i - LATTICE_FRAME
        return j >= 0 and j % pitch < LATTICE_HOLE and j // pitch < count

    rows = []
    for y in range(height):
        row = []
        for x in range(width):
            in_col = in_hole(x, LATTICE_COLUMNS)
            if in_col and in_hole(y, LATTICE_ROWS):
                row.append(wood + (0,))
                continue
            # The vertical bars (and the frame's sides) run the full height; the horizontal
            # ones lie between them. Each bar is 0-8 % darker than `wood`, and each line of
            # texels along it (its grain) another 0-9 %.
            vertical = not in_col
            bar = (x + LATTICE_BAR) // pitch if vertical else 1000 + (y + LATTICE_BAR) // pitch
            across = x if vertical else y
            percent = 100 - hash32(bar) % 3 * 4 - hash32(bar, across) % 4 * 3
            row.append(shade(wood, percent) + (255,))
        rows.append(row)
    return width, height, rows


def detail_room():
    b = Builder()
    tiles_tex = b.texture("bevelled tiles (normals)", "detail-room-floor-normal.png", 9729)
    lattice_tex = b.texture("lattice", "detail-room-lattice.png", 9728)  # NEAREST
    normals = tile_normal_texture()
    check_tile_normals(normals)
    write_normal_texture("detail-room-floor-normal.png", normals)
    lattice_image = lattice_texture()
    write_rgba_texture("detail-room-lattice.png", lattice_image)

    floor = glossy_floor(b, normal_texture=tiles_tex)
    floor_uvs = lambda p: planar_uvs(p, (0.0, 0.0, 0.0), X_AXIS, Z_AXIS, DETAIL_TILE_M)
    add_cornell_surfaces(b, glossy_room_surfaces(b, floor, floor_uvs))

    # The lattice: a quad from the floor up, its front face (towards the camera, -Z) wound
    # counter-clockwise; u from the camera's left (larger x) to its right, v down from the
    # top, the texture once over the quad.
    lattice = b.glossy_material(
        "lattice, wood", (1.0, 1.0, 1.0), 0.0, 0.6, texture=lattice_tex, alpha_cutoff=0.5
    )
    width, height = lattice_size()
    x0 = LATTICE_RIGHT_X_MM
    x1 = x0 + width * LATTICE_TEXEL_MM
    top = height * LATTICE_TEXEL_MM
    z = CORNELL_MM["back_wall"][0][0][2] - LATTICE_GAP_MM
    quad = [(x1, 0.0, z), (x0, 0.0, z), (x0, top, z), (x1, top, z)]
    points, triangles = quads_to_mesh([quad])
    for t in triangles:
        assert face_normal(points, t)[2] < 0.0  # the front faces the camera
    # Clear of the tall block in the camera's view: its rightmost corner in the image,
    # (265, 296) mm, seen from the camera, passes the lattice's plane at a larger x.
    cx, _, cz = CAMERA_POSITION_MM
    assert x1 < cx + (265.0 - cx) * (z - cz) / (296.0 - cz) - 5.0, x1
    uvs = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    b.mesh("lattice", points, triangles, lattice, component_type=5121, uvs=uvs)

    cornell_camera(b)
    write_scene(
        b,
        "detail-room",
        "the glossy room with a normal-mapped tiled floor and an alpha-masked lattice, metres",
    )


# ---------------------------------------------------------------------------------------------
# Known-answer scenes
# ---------------------------------------------------------------------------------------------

# White furnace: a closed sphere of radius 1 m, albedo RHO, emission LE on both faces.
FURNACE_RHO = 0.8
FURNACE_LE = 1.0
FURNACE_SUBDIVISIONS = 2  # 20 * 4^2 = 320 triangles


def icosphere(subdivisions):
    t = (1.0 + math.sqrt(5.0)) / 2.0
    points = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
        (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
        (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]
    points = [normalise(p) for p in points]
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
        (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
        (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
        (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]
    for _ in range(subdivisions):
        cache = {}

        def midpoint(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                a, b = points[i], points[j]
                points.append(normalise(((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2)))
                cache[key] = len(points) - 1
            return cache[key]

        new_faces = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
    return points, faces


def normalise(p):
    n = math.sqrt(dot(p, p))
    return (p[0] / n, p[1] / n, p[2] / n)


def furnace():
    b = Builder()
    m = b.material(
        "furnace wall", (FURNACE_RHO,) * 3, emission=(FURNACE_LE,) * 3, double_sided=True
    )
    points, faces = icosphere(FURNACE_SUBDIVISIONS)
    # Wind every face inwards (front faces look at the centre, where the camera is).
    faces = [f if dot(face_normal(points, f), points[f[0]]) < 0 else (f[0], f[2], f[1]) for f in faces]
    b.mesh("sphere", points, faces, m, component_type=5125)
    # Camera at the centre looking down -Z (no rotation).
    b.camera("centre", math.radians(60.0), 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    doc = b.document(
        "white furnace, albedo %g, emission %g: radiance Le/(1-rho) everywhere" % (FURNACE_RHO, FURNACE_LE),
        None,
    )
    write_glb(os.path.join(HERE, "furnace.glb"), doc, b.data)


# Disk light: radius DISK_R at height DISK_H over the plane y = 0, emitting DISK_L downwards
# (single-sided, albedo 0 so nothing reflects off it), the plane's albedo PLANE_RHO.
DISK_R = 0.5
DISK_H = 1.0
DISK_L = 4.0
DISK_SEGMENTS = 256
PLANE_RHO = 0.5
PLANE_HALF = 10.0
# The camera sits on the axis at height CAMERA_H looking straight down with a narrow field of
# view, so every pixel sees the plane within a small distance of the axis.
DISK_CAMERA_H = 0.5
DISK_CAMERA_YFOV = math.radians(2.0)


def disk_light():
    b = Builder()
    plane_m = b.material("plane", (PLANE_RHO,) * 3)
    light_m = b.material("disk light", (0.0, 0.0, 0.0), emission=(DISK_L,) * 3, double_sided=False)
    s = PLANE_HALF
    plane_points = [(-s, 0.0, -s), (-s, 0.0, s), (s, 0.0, s), (s, 0.0, -s)]
    plane_tris = [(0, 1, 2), (0, 2, 3)]
    for t in plane_tris:
        assert face_normal(plane_points, t)[1] > 0.0  # the plane faces up
    b.mesh("plane", plane_points, plane_tris, plane_m, component_type=5121)
    # A fan around the centre: triangle (centre, p_i, p_i+1) has normal along
    # (cos a_i, 0, sin a_i) x (cos a_i+1, 0, sin a_i+1), whose y is sin(a_i - a_i+1) < 0: down.
    disk_points = [(0.0, DISK_H, 0.0)]
    for i in range(DISK_SEGMENTS):
        a = 2.0 * math.pi * i / DISK_SEGMENTS
        disk_points.append((DISK_R * math.cos(a), DISK_H, DISK_R * math.sin(a)))
    disk_tris = [(0, 1 + i, 1 + (i + 1) % DISK_SEGMENTS) for i in range(DISK_SEGMENTS)]
    for t in disk_tris:
        assert face_normal(disk_points, t)[1] < 0.0  # the light faces down
    b.mesh("disk light", disk_points, disk_tris, light_m, component_type=5123)
    # Looking straight down: a rotation of -90 degrees about X takes local -Z to world -Y.
    half = math.radians(-90.0) / 2.0
    b.camera(
        "above the axis",
        DISK_CAMERA_YFOV,
        1.0,
        (0.0, DISK_CAMERA_H, 0.0),
        (math.sin(half), 0.0, 0.0, math.cos(half)),
    )
    doc = b.document(
        "disk light r=%g h=%g L=%g over a plane of albedo %g" % (DISK_R, DISK_H, DISK_L, PLANE_RHO),
        None,
    )
    doc["buffers"][0]["uri"] = data_uri(b.data)
    write_gltf(os.path.join(HERE, "disk-light.gltf"), doc)


def ao_plane():
    b = Builder()
    m = b.material("plane", (0.5, 0.5, 0.5))
    s = 10.0
    points = [(-s, 0.0, -s), (-s, 0.0, s), (s, 0.0, s), (s, 0.0, -s)]
    tris = [(0, 1, 2), (0, 2, 3)]
    b.mesh("plane", points, tris, m, component_type=5125)
    half = math.radians(-90.0) / 2.0
    # 1 m above the plane, 60 degree field of view: the view covers |x|, |z| < tan(30 deg) m.
    b.camera("above", math.radians(60.0), 1.0, (0.0, 1.0, 0.0), (math.sin(half), 0.0, 0.0, math.cos(half)))
    doc = b.document("a plane under nothing: ambient occlusion 1 everywhere", None)
    doc["buffers"][0]["uri"] = data_uri(b.data)
    write_gltf(os.path.join(HERE, "ao-plane.gltf"), doc)


if __name__ == "__main__":
    cornell_box()
    indirect_room()
    textured_room()
    glossy_room()
    metal_floor_room()
    cornell_dolly()
    cornell_push()
    detail_room()
    furnace()
    disk_light()
    ao_plane()
