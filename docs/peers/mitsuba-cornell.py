#!/usr/bin/env python3
"""Renders irr's Cornell box (assets/cornell-box.gltf) with Mitsuba 3's path tracer, for the
efficiency comparison in docs/performance.md: the same triangles, albedos, emitter, camera and box pixel
filter, so that both renderers converge to the same image.

Usage: python3 docs/peers/mitsuba-cornell.py REFERENCE.exr [SPP] [THREADS] [VARIANT]
       python3 docs/peers/mitsuba-cornell.py REFERENCE.exr IMAGE.exr   (scores another image, e.g. irr's)
  REFERENCE.exr: irr's high-spp reference of the same view at the same size (for example the
  one `cargo xtask compare` caches under target/compare/cache/), RGB, linear.
Prints Mitsuba's render time and its relMSE against the reference (the same metric as
`cargo xtask compare`: mean over pixels and channels of (x - r)^2 / (r^2 + 0.01)).

Needs `pip install mitsuba==3.5.2 drjit==0.4.6 numpy` (3.9's LLVM backend needs a newer LLVM than
this machine's 15; 3.5 runs on it). The meshes go to Mitsuba as OBJ files in a
temporary folder, with face normals (no smoothing). Materials: irr's surfaces are Lambertian and
reflect on both sides, so each BSDF is Mitsuba's `diffuse` inside `twosided`; the light emits
from its front face only (glTF doubleSided = false), as Mitsuba's `area` emitter does. Depth:
irr's default is 64 bounces, Mitsuba's max_depth counts vertices, so 65; Russian roulette from
depth 5 in both.
"""

import json
import math
import os
import struct
import sys
import tempfile
import time

import mitsuba as mi
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ASSETS = os.path.join(HERE, "..", "..", "assets")


def accessor(doc, blob, i):
    a = doc["accessors"][i]
    v = doc["bufferViews"][a["bufferView"]]
    n = {"SCALAR": 1, "VEC3": 3}[a["type"]]
    fmt = {5126: "f", 5125: "I", 5123: "H", 5121: "B"}[a["componentType"]]
    size = struct.calcsize(fmt)
    off = v.get("byteOffset", 0) + a.get("byteOffset", 0)
    data = struct.unpack_from("<" + fmt * (n * a["count"]), blob, off)
    return np.array(data).reshape(-1, n) if n > 1 else np.array(data)


def quat_to_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def rel_mse(img, reference):
    return float(np.mean((img - reference) ** 2 / (reference ** 2 + 0.01)))


def read_rgb(path):
    return np.array(mi.Bitmap(path).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))


def main():
    reference_path = sys.argv[1]
    if len(sys.argv) > 2 and sys.argv[2].endswith(".exr"):
        mi.set_variant("scalar_rgb")
        print(f"{sys.argv[2]}: relMSE {rel_mse(read_rgb(sys.argv[2]), read_rgb(reference_path)):.3e}")
        return
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    threads = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    variant = sys.argv[4] if len(sys.argv) > 4 else "llvm_ad_rgb"
    mi.set_variant(variant)
    import drjit as dr
    dr.set_thread_count(threads)

    doc = json.load(open(os.path.join(ASSETS, "cornell-box.gltf")))
    blob = open(os.path.join(ASSETS, doc["buffers"][0]["uri"]), "rb").read()
    reference = read_rgb(reference_path)
    height, width = reference.shape[:2]

    tmp = tempfile.mkdtemp(prefix="irr-mitsuba-")
    scene = {"type": "scene",
             "integrator": {"type": "path", "max_depth": 65, "rr_depth": 5}}
    for k, node in enumerate(doc["nodes"]):
        if "mesh" in node:
            for p, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
                pos = accessor(doc, blob, prim["attributes"]["POSITION"])
                idx = accessor(doc, blob, prim["indices"]).reshape(-1, 3)
                mat = doc["materials"][prim["material"]]
                obj = os.path.join(tmp, f"m{k}_{p}.obj")
                with open(obj, "w") as f:
                    for v in pos:
                        f.write(f"v {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
                    for t in idx:
                        f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")
                rho = mat["pbrMetallicRoughness"]["baseColorFactor"][:3]
                shape = {"type": "obj", "filename": obj, "face_normals": True,
                         "bsdf": {"type": "twosided",
                                  "bsdf": {"type": "diffuse",
                                           "reflectance": {"type": "rgb", "value": rho}}}}
                if "emissiveFactor" in mat:
                    strength = mat.get("extensions", {}).get(
                        "KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
                    le = [c * strength for c in mat["emissiveFactor"]]
                    shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": le}}
                scene[f"m{k}_{p}"] = shape
        if "camera" in node:
            cam = doc["cameras"][node["camera"]]["perspective"]
            t = np.array(node.get("translation", [0, 0, 0]))
            r = quat_to_matrix(node.get("rotation", [0, 0, 0, 1]))
            forward = r @ np.array([0, 0, -1.0])
            up = r @ np.array([0, 1.0, 0])
            scene["sensor"] = {
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
    s = mi.load_dict(scene)
    # One warm-up render compiles the kernels (Mitsuba's JIT), as a user's second render would.
    mi.render(s, spp=1)
    start = time.time()
    image = mi.render(s, spp=spp, seed=1)
    dr.eval(image)
    img = np.array(image)
    seconds = time.time() - start
    rel = rel_mse(img, reference)
    print(f"mitsuba {variant} {width}x{height} {spp} spp on {threads} threads: "
          f"{seconds:.2f} s, relMSE {rel:.3e}, mean {img.mean(axis=(0, 1))}, "
          f"reference mean {reference.mean(axis=(0, 1))}")


if __name__ == "__main__":
    main()
