#!/usr/bin/env python3
"""Writes irr's scenes in assets/ as glTF 2.0 (metres, +Y up, right-handed).

Run from anywhere with `python3 assets/generate.py`; it rewrites, next to itself:

- cornell-box.gltf + cornell-box.bin: the default scene, the Cornell box from Cornell's
  published "Cornell Box Data" (geometry in mm, converted to metres), with the camera as a glTF
  perspective camera. External buffer.
- furnace.glb: the white furnace, a closed sphere with albedo RHO and emission LE: every pixel sees
  LE / (1 - RHO) (with unbounded depth). Binary glTF.
- disk-light.gltf: a disk light of radius R at height H over a large diffuse plane; the irradiance
  on the axis is E = pi L r^2 / (r^2 + h^2). Buffer embedded as a data URI.
- ao-plane.gltf: one plane and nothing above it, no emitter: ambient occlusion is exactly 1.
  Buffer embedded as a data URI.

Only the standard library is used (json, struct, base64, math). The output is deterministic:
running the script twice gives the same bytes, so the committed files can be checked by
re-running it and asking git for a diff.
"""

import base64
import json
import math
import os
import struct

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

    def material(self, name, albedo, emission=(0.0, 0.0, 0.0), double_sided=True):
        """A Lambertian material: glTF's metallic-roughness model with metallic 0, roughness 1.

        `emission` is the emitted radiance (W sr^-1 m^-2 per channel); glTF clamps emissiveFactor
        to [0, 1], so a brighter emission is written as emissiveFactor = emission / max(emission)
        times KHR_materials_emissive_strength = max(emission).
        """
        m = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [albedo[0], albedo[1], albedo[2], 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "doubleSided": double_sided,
        }
        peak = max(emission)
        if peak > 0.0:
            m["emissiveFactor"] = [e / peak for e in emission]
            if peak != 1.0:
                m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": peak}}
                self.extensions_used.add("KHR_materials_emissive_strength")
        self.materials.append(m)
        return len(self.materials) - 1

    def mesh(self, name, points, triangles, material, component_type=5123):
        check_indices(points, triangles, component_type)
        prim = {
            "attributes": {"POSITION": self.positions(points)},
            "indices": self.indices(triangles, component_type),
            "material": material,
            "mode": 4,  # TRIANGLES
        }
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
        if self.extensions_used:
            doc["extensionsUsed"] = sorted(self.extensions_used)
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


def cornell_box():
    b = Builder()
    white = b.material("white", WHITE)
    red = b.material("red", RED)
    green = b.material("green", GREEN)
    # Single-sided: the light emits from its front face only, downwards into the box.
    light = b.material("light", LIGHT_ALBEDO, emission=LIGHT_RADIANCE, double_sided=False)
    surfaces = [
        ("floor", white),
        ("ceiling", white),
        ("back_wall", white),
        ("right_wall", green),
        ("left_wall", red),
        ("short_block", white),
        ("tall_block", white),
        ("light", light),
    ]
    centre = (0.278, 0.2744, 0.2796)
    for name, material in surfaces:
        points, triangles = quads_to_mesh(CORNELL_MM[name])
        # The listing winds every surface so that its front face looks into the room (walls,
        # floor, ceiling, light) or out of the block (blocks). Check it, since the light emits
        # from its front face only.
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
        b.mesh(name, points, triangles, material, component_type=5123)
    # glTF cameras look down their local -Z with +Y up; the Cornell camera looks down world +Z
    # with +Y up: a half turn about Y, the unit quaternion (x, y, z, w) = (0, 1, 0, 0). Its right
    # (local +X) is then world -X, so the red wall (x = 0.55 m) is on the left, as in the photos.
    b.camera(
        "cornell camera",
        CAMERA_YFOV,
        1.0,
        tuple(c / 1000.0 for c in CAMERA_POSITION_MM),
        (0.0, 1.0, 0.0, 0.0),
    )
    doc = b.document("Cornell Box Data (Cornell University PCG), metres", "cornell-box.bin")
    write_gltf(os.path.join(HERE, "cornell-box.gltf"), doc)
    with open(os.path.join(HERE, "cornell-box.bin"), "wb") as f:
        f.write(bytes(b.data))


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
    furnace()
    disk_light()
    ao_plane()
