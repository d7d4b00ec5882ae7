#!/usr/bin/env python3
"""Renders irr's glossy room (assets/glossy-room.gltf) with Mitsuba 3's path tracer, to compare
irr's path tracer's efficiency with Mitsuba's on glossy materials: the same triangles, texture,
emitter, camera and box pixel filter, and each glTF metallic-roughness material mapped to the
closest Mitsuba BSDF. The two BRDFs are not identical (see "Materials" below), so the two
renderers converge to slightly different images: each renderer is scored against a reference of
its own (irr's against irr's, Mitsuba's against one from `--reference`), and what is compared is
efficiency, 1/(relMSE * seconds), not the images.

Usage:
  python3 docs/peers/mitsuba-glossy.py --reference OUT.exr SPP [THREADS] [SIZE]
      renders Mitsuba's own reference, SIZE x SIZE (default 256), in passes of at most 64 spp
      (independent seeds, averaged), and writes it to OUT.exr (RGB, linear, float32).
  python3 docs/peers/mitsuba-glossy.py REFERENCE.exr [SPP] [THREADS] [VARIANT] [-o IMAGE.exr]
      renders at REFERENCE.exr's size with SPP samples per pixel (default 256) on THREADS threads
      (default 2) and prints Mitsuba's render time and its relMSE against REFERENCE.exr;
      -o also writes the image.
  python3 docs/peers/mitsuba-glossy.py REFERENCE.exr IMAGE.exr
      scores another image (e.g. irr's, against irr's reference).
relMSE is the metric of `cargo xtask compare` and of mitsuba-cornell.py: the mean over pixels and
channels of (x - r)^2 / (r^2 + 0.01). Timing as in mitsuba-cornell.py: one 1-spp warm-up render
compiles Mitsuba's kernels (as a user's second render would find them), then one render of SPP
samples in one pass is timed (so at 256 x 256 x SPP it holds that many paths' state in memory).

Needs `pip install mitsuba==3.5.2 drjit==0.4.6 numpy` (see mitsuba-cornell.py for why 3.5).

Scene conversion. The meshes go to Mitsuba as OBJ files in a temporary folder (as in
mitsuba-cornell.py), with face normals and, where the primitive has TEXCOORD_0, its (u, v)
written unchanged with `flip_tex_coords` off: glTF's (0, 0) is the image's top-left corner with v
growing down the rows, which is Mitsuba's own convention for a bitmap texture (its OBJ loader's
default flip converts OBJ's bottom-up v into it). Mitsuba's triangles face the side from which
their vertices run counter-clockwise, as glTF's do, so no winding is flipped. The camera is the
glTF camera node (translation, rotation quaternion, yfov). Depth: irr's default is 64 bounces,
Mitsuba's max_depth counts path segments (1 = emitters seen directly), so 65; Russian roulette
from depth 5 in both.

Materials (glTF 2.0 metallic-roughness, Appendix B; irr implements it as written there, with
Schlick's Fresnel and the height-correlated Smith visibility):
- specularFactor 0 (KHR_materials_specular), metallic 0: Lambertian, Mitsuba's `diffuse` with the
  base colour. Exact.
- metallicFactor 1: Mitsuba's `principled` with metallic 1, base_color = the base colour,
  roughness = roughnessFactor (its GGX width is roughness^2, as glTF's, floored at 1e-3 as irr's).
  With metallic 1 its only lobe is GGX reflection with Schlick's Fresnel from F0 = base colour
  to 1 at grazing: glTF's conductor_fresnel exactly. Mitsuba's `roughconductor` was not used: it
  takes a complex IOR (eta, k), and with the "none" material (F = 1) times a
  specular_reflectance of the base colour it would have no Schlick rise to white at grazing
  angles.
  Difference from glTF: Mitsuba's Smith term is separable, G1(wi) G1(wo), glTF's (and irr's)
  height-correlated; the separable one is a little darker where both directions are far from
  the normal.
- metallicFactor 0 with the default specularFactor 1 (the floor, the poster, the matte walls and
  the blue plastic): Mitsuba's `principled` with metallic 0, specular 0.5 (its IOR is
  2 / (1 - sqrt(0.08 specular)) - 1 = 1.5, F0 = 4 %, glTF's dielectric), spec_tint 0, sheen 0,
  clearcoat 0, spec_trans 0, base_color = the base colour (times the baseColorTexture),
  roughness = roughnessFactor. Differences from glTF's fresnel_mix(ior 1.5, Lambertian base,
  GGX layer):
  * the specular layer's Fresnel is the exact dielectric one, not Schlick's (equal at normal and
    grazing incidence; at 60 degrees 0.089 against Schlick's 0.070);
  * the diffuse lobe is Disney's (Burley 2012): base/pi times (1 - F_L/2)(1 - F_V/2) plus a
    retro-reflection term growing with roughness, not Lambertian, and it is not weighted by
    (1 - F(V.H)): the two lobes add. Directional albedo of a white base (Mitsuba's by its own
    sampler, glTF's by Monte Carlo of Appendix B), seen head-on / at cos 0.3:
    roughness 0.2: Mitsuba 1.026 / 1.141, glTF 1.000 / 1.144;
    roughness 0.35: 1.036 / 1.138 against 0.999 / 1.100;
    roughness 0.5: 1.045 / 1.127 against 0.997 / 1.045;
    roughness 1: 1.046 / 1.176 against 0.972 / 0.980.
    So the matte walls (roughness 1) are where the two differ most, 8 % head-on and 20 %
    obliquely: Mitsuba's image is brighter there (its mean is about 8 % / 6 % / 2 % above
    irr's in R / G / B, up to ~25 % in the corners where the walls are seen edge-on);
  * the separable Smith term, as for the metal.
  Mitsuba's `roughplastic` (ggx, alpha = roughness^2, int_ior 1.5, diffuse_reflectance = the
  base colour, nonlinear false), the model closest in form to glTF's (a Lambertian base under a
  GGX dielectric layer, weighted by the layer's transmittance), was tried and rejected: in
  Mitsuba 3.5.2 it loses energy as its roughness grows. The directional albedo of a white
  roughplastic at normal incidence (its own importance sampler, and a uniform-hemisphere check
  of its eval, agree) is 0.965 at alpha 0.04, 0.88 at 0.12 (the floor), 0.74 at 0.25 (the
  poster), 0.34 at 1 (the matte walls), where glTF's stays near 1: the walls would be a third
  as bright (cf. mitsuba3 issue #1155, a furnace test of roughplastic at alpha 1).
- Textures: the poster's baseColorTexture is an sRGB PNG; it is decoded to linear RGB, multiplied
  by baseColorFactor, and given to Mitsuba's `bitmap` (raw, bilinear, wrap repeat: the glTF
  sampler's LINEAR and REPEAT; no mip maps, as irr has none).
- The light: its emissiveFactor times KHR_materials_emissive_strength as the radiance of an
  `area` emitter (which emits from the front face only, as a single-sided glTF emitter), on a
  `diffuse` BSDF with its base colour (the light's material has specularFactor 0).
- Sidedness: doubleSided materials are wrapped in Mitsuba's `twosided`; single-sided ones (the
  light) are not. (With this camera no back face of the room is reachable anyway.)
Only these material kinds are supported (a metallicFactor strictly between 0 and 1, or another
specularFactor, raises an error).
"""

import json
import os
import sys
import tempfile
import time

import mitsuba as mi
import numpy as np

from gltf_peer import accessor, emitter, read_rgb, rel_mse, sensor, timed_render

HERE = os.path.dirname(os.path.abspath(__file__))
ASSETS = os.path.join(HERE, "..", "..", "assets")
SCENE = "glossy-room.gltf"
# The most samples per pixel `--reference` renders in one pass (memory: Mitsuba's wavefront holds
# width x height x spp paths).
PASS_SPP = 64


def base_colour(doc, mat):
    """The base colour: an RGB value, or a `bitmap` texture (the sRGB image decoded to linear
    RGB and multiplied by baseColorFactor)."""
    pbr = mat.get("pbrMetallicRoughness", {})
    factor = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])[:3]
    if "baseColorTexture" not in pbr:
        return {"type": "rgb", "value": factor}
    info = pbr["baseColorTexture"]
    assert info.get("texCoord", 0) == 0, "only TEXCOORD_0"
    texture = doc["textures"][info["index"]]
    sampler = doc["samplers"][texture["sampler"]] if "sampler" in texture else {}
    image = doc["images"][texture["source"]]
    linear = np.array(mi.Bitmap(os.path.join(ASSETS, image["uri"])).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))
    wrap = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
    assert sampler.get("wrapS", 10497) == sampler.get("wrapT", 10497), "one wrap mode for both"
    return {"type": "bitmap",
            "bitmap": mi.Bitmap(np.ascontiguousarray(linear * np.array(factor, dtype=np.float32))),
            "raw": True,
            "filter_type": "nearest" if sampler.get("magFilter") == 9728 else "bilinear",
            "wrap_mode": wrap[sampler.get("wrapS", 10497)]}


def bsdf(doc, mat):
    """The Mitsuba BSDF for a glTF material (the module's docstring gives the mapping)."""
    pbr = mat.get("pbrMetallicRoughness", {})
    metallic = pbr.get("metallicFactor", 1.0)
    roughness = pbr.get("roughnessFactor", 1.0)
    specular = mat.get("extensions", {}).get("KHR_materials_specular", {}).get(
        "specularFactor", 1.0)
    base = base_colour(doc, mat)
    if metallic == 1.0:
        b = {"type": "principled", "base_color": base, "metallic": 1.0, "roughness": roughness}
    elif metallic == 0.0 and specular == 0.0:
        b = {"type": "diffuse", "reflectance": base}
    elif metallic == 0.0 and specular == 1.0:
        b = {"type": "principled", "base_color": base, "metallic": 0.0, "roughness": roughness,
             "specular": 0.5, "spec_tint": 0.0, "sheen": 0.0, "clearcoat": 0.0,
             "spec_trans": 0.0}
    else:
        raise NotImplementedError(
            f"{mat.get('name')}: metallic {metallic}, specularFactor {specular}")
    return {"type": "twosided", "bsdf": b} if mat.get("doubleSided", False) else b


def load_scene(width, height, spp):
    doc = json.load(open(os.path.join(ASSETS, SCENE)))
    blob = open(os.path.join(ASSETS, doc["buffers"][0]["uri"]), "rb").read()
    tmp = tempfile.mkdtemp(prefix="irr-mitsuba-")
    scene = {"type": "scene",
             "integrator": {"type": "path", "max_depth": 65, "rr_depth": 5}}
    for k, node in enumerate(doc["nodes"]):
        if "mesh" in node:
            # The glossy room's mesh nodes carry no transforms: the positions are world space.
            assert not any(key in node for key in ("matrix", "translation", "rotation", "scale"))
            for p, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
                assert prim.get("mode", 4) == 4, "triangles only"
                pos = accessor(doc, blob, prim["attributes"]["POSITION"])
                idx = accessor(doc, blob, prim["indices"]).reshape(-1, 3)
                uv = (accessor(doc, blob, prim["attributes"]["TEXCOORD_0"])
                      if "TEXCOORD_0" in prim["attributes"] else None)
                mat = doc["materials"][prim["material"]]
                obj = os.path.join(tmp, f"m{k}_{p}.obj")
                with open(obj, "w") as f:
                    for v in pos:
                        f.write(f"v {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
                    if uv is not None:
                        for t in uv:
                            f.write(f"vt {float(t[0])!r} {float(t[1])!r}\n")
                        for t in idx:
                            f.write(f"f {t[0] + 1}/{t[0] + 1} {t[1] + 1}/{t[1] + 1} "
                                    f"{t[2] + 1}/{t[2] + 1}\n")
                    else:
                        for t in idx:
                            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")
                shape = {"type": "obj", "filename": obj, "face_normals": True,
                         "flip_tex_coords": False, "bsdf": bsdf(doc, mat)}
                if emitter(mat) is not None:
                    shape["emitter"] = emitter(mat)
                scene[f"m{k}_{p}"] = shape
        if "camera" in node:
            scene["sensor"] = sensor(doc, node, width, height, spp)
    return mi.load_dict(scene)


def set_up(variant, threads):
    mi.set_variant(variant)
    import drjit as dr
    dr.set_thread_count(threads)
    return dr


def render_reference(args):
    out, spp = args[0], int(args[1])
    threads = int(args[2]) if len(args) > 2 else 2
    size = int(args[3]) if len(args) > 3 else 256
    dr = set_up("llvm_ad_rgb", threads)
    s = load_scene(size, size, min(spp, PASS_SPP))
    total = np.zeros((size, size, 3))
    done, start = 0, time.time()
    for k in range(0, spp, PASS_SPP):
        n = min(PASS_SPP, spp - k)
        image = mi.render(s, spp=n, seed=1000 + k)
        dr.eval(image)
        total += np.array(image, dtype=np.float64) * n
        done += n
    img = (total / done).astype(np.float32)
    mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(out)
    print(f"{out}: mitsuba reference {size}x{size} {done} spp on {threads} threads, "
          f"{time.time() - start:.1f} s, mean {img.mean(axis=(0, 1))}")


def main():
    args = sys.argv[1:]
    if args and args[0] == "--reference":
        render_reference(args[1:])
        return
    save = None
    if "-o" in args:
        i = args.index("-o")
        save = args[i + 1]
        del args[i:i + 2]
    reference_path = args[0]
    if len(args) > 1 and args[1].endswith(".exr"):
        mi.set_variant("scalar_rgb")
        print(f"{args[1]}: relMSE {rel_mse(read_rgb(args[1]), read_rgb(reference_path)):.3e}")
        return
    spp = int(args[1]) if len(args) > 1 else 256
    threads = int(args[2]) if len(args) > 2 else 2
    variant = args[3] if len(args) > 3 else "llvm_ad_rgb"
    dr = set_up(variant, threads)
    reference = read_rgb(reference_path)
    height, width = reference.shape[:2]
    s = load_scene(width, height, spp)
    img, seconds = timed_render(s, spp)
    rel = rel_mse(img, reference)
    if save:
        mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(save)
    print(f"mitsuba {variant} {width}x{height} {spp} spp on {threads} threads: "
          f"{seconds:.2f} s, relMSE {rel:.3e}, mean {img.mean(axis=(0, 1))}, "
          f"reference mean {reference.mean(axis=(0, 1))}")


if __name__ == "__main__":
    main()
