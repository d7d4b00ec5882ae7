"""What the peer scripts (mitsuba-cornell.py, mitsuba-glossy.py) share: reading irr's glTF
assets (accessors, the camera node, emission) into Mitsuba 3 scene dictionaries, and the relMSE
that `cargo xtask compare` reports. Imported from the scripts' own folder."""

import math
import struct

import mitsuba as mi
import numpy as np


def accessor(doc, blob, i):
    """Accessor `i` of `doc` from the buffer bytes `blob` (tightly packed SCALAR, VEC2 or VEC3)."""
    a = doc["accessors"][i]
    v = doc["bufferViews"][a["bufferView"]]
    n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
    fmt = {5126: "f", 5125: "I", 5123: "H", 5121: "B"}[a["componentType"]]
    off = v.get("byteOffset", 0) + a.get("byteOffset", 0)
    assert v.get("byteStride", struct.calcsize(fmt) * n) == struct.calcsize(fmt) * n, "strided"
    data = struct.unpack_from("<" + fmt * (n * a["count"]), blob, off)
    return np.array(data).reshape(-1, n) if n > 1 else np.array(data)


def quat_to_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def timed_render(scene, spp):
    """The image of `scene` at `spp` (seed 1) and the seconds it took, after one warm-up
    render that compiles the kernels (Mitsuba's JIT), as a user's second render would."""
    import time

    import drjit as dr

    mi.render(scene, spp=1)
    start = time.time()
    image = mi.render(scene, spp=spp, seed=1)
    dr.eval(image)
    img = np.array(image)
    return img, time.time() - start


def rel_mse(img, reference):
    return float(np.mean((img - reference) ** 2 / (reference ** 2 + 0.01)))


def read_rgb(path):
    return np.array(mi.Bitmap(path).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))


def emitter(mat):
    """Mitsuba's `area` emitter for a glTF material (emissiveFactor times
    KHR_materials_emissive_strength), or None for a material that does not emit."""
    if "emissiveFactor" not in mat:
        return None
    strength = mat.get("extensions", {}).get(
        "KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    le = [c * strength for c in mat["emissiveFactor"]]
    return {"type": "area", "radiance": {"type": "rgb", "value": le}}


def sensor(doc, node, width, height, spp):
    """Mitsuba's perspective sensor for the glTF camera `node` (translation, rotation, yfov), a
    width x height film with a box filter, and an independent sampler of `spp`."""
    cam = doc["cameras"][node["camera"]]["perspective"]
    t = np.array(node.get("translation", [0, 0, 0]))
    r = quat_to_matrix(node.get("rotation", [0, 0, 0, 1]))
    forward = r @ np.array([0, 0, -1.0])
    up = r @ np.array([0, 1.0, 0])
    return {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(cam["yfov"]),
        "near_clip": cam.get("znear", 0.001),
        "to_world": mi.ScalarTransform4f().look_at(
            origin=t.tolist(), target=(t + forward).tolist(), up=up.tolist()),
        "film": {"type": "hdrfilm", "width": width, "height": height,
                 "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": spp},
    }
