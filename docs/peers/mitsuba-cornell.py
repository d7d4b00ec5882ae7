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
import os
import sys
import tempfile

import mitsuba as mi
import numpy as np

from gltf_peer import accessor, emitter, read_rgb, rel_mse, sensor, timed_render

HERE = os.path.dirname(os.path.abspath(__file__))
ASSETS = os.path.join(HERE, "..", "..", "assets")


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
                if emitter(mat) is not None:
                    shape["emitter"] = emitter(mat)
                scene[f"m{k}_{p}"] = shape
        if "camera" in node:
            scene["sensor"] = sensor(doc, node, width, height, spp)
    s = mi.load_dict(scene)
    img, seconds = timed_render(s, spp)
    rel = rel_mse(img, reference)
    print(f"mitsuba {variant} {width}x{height} {spp} spp on {threads} threads: "
          f"{seconds:.2f} s, relMSE {rel:.3e}, mean {img.mean(axis=(0, 1))}, "
          f"reference mean {reference.mean(axis=(0, 1))}")


if __name__ == "__main__":
    main()
