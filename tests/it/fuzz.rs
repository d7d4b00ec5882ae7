//! Structured mutation fuzzing of the two readers of untrusted files, as the `irr` command uses
//! them: the glTF/GLB loader (`irr_render::load_scene`, BVH build included), followed by a tiny
//! render of every scene that loads (path tracer and irradiance cache, 4×4 pixels, 1 sample),
//! and the persistent cache file reader (`irr_render::read_cache_file`, which reads
//! irr-cache's format inside), followed by a render from every cache it accepts. No file may
//! make either panic or hang.
//!
//! Each case is made from a seed (irr's assets and small generated files) by a few mutations
//! drawn from a counter-based generator: byte flips, interesting bytes, truncations, splices
//! and, for glTF, edits of the JSON tree (huge or negative counts, wrong types, hostile URIs,
//! removed members, swapped camera types, sparse blocks) with the GLB container rebuilt around
//! the edited JSON so the edit reaches the loader. Every case runs inside `catch_unwind`; a panic,
//! or a case slower than [`SLOW`], fails the test and leaves the case in `target/fuzz-crashes/`
//! with the command to replay it.
//!
//! - `cargo test -p irr-tests --test it fuzz`: a fixed, fast set of cases (the same every run),
//!   plus a replay of every file in `tests/fuzz-corpus/` (the crashes found so far, kept as
//!   regression inputs).
//! - `IRR_FUZZ_ITERS=200000 IRR_FUZZ_SEED=7 cargo test --release -p irr-tests --test it fuzz`:
//!   a longer run (see docs/fuzzing.md); it prints the number of executions.
//! - `IRR_FUZZ_REPLAY=path` replays one file (a `.gltf`/`.glb` scene or an `.irrc` cache file);
//!   `IRR_FUZZ_DEBUG=1` prints every refusal (to tune the mutations).

use crate::support::read;
use irr_render::{
    IcSettings, IrradianceCacheIntegrator, PathTracer, RenderSettings, build_cache, render,
};
use irr_scene::testutil::base64;
use serde_json::{Value, json};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A case slower than this is reported as a hang. Every seed and mutation is small (under
/// 64 KiB), and such a file loads in milliseconds; 10 s is far above any honest case even in a
/// debug build on a loaded machine.
const SLOW: Duration = Duration::from_secs(10);

/// Cases of each fuzzer in an ordinary `cargo test`.
const DEFAULT_ITERS: u64 = 600;

fn iterations() -> u64 {
    std::env::var("IRR_FUZZ_ITERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_ITERS)
}

fn base_seed() -> u64 {
    std::env::var("IRR_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(12)
}

/// SplitMix64: a counter-based generator, so case k of seed s is the same on every machine.
struct Rng(u64);

impl Rng {
    fn new(seed: u64, case: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ case.wrapping_mul(0xD1B5_4A32_D192_ED03))
    }
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in 0..n (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Where failing cases are kept.
fn crash_dir() -> PathBuf {
    workspace().join("target").join("fuzz-crashes")
}

// ---------------------------------------------------------------------------------------------
// The glTF corpus.

/// A seed: the scene's bytes and whether it is a .glb.
#[derive(Clone)]
struct Seed {
    name: String,
    bytes: Vec<u8>,
    glb: bool,
}

/// A GLB container around `json` and `bin` (glTF 2.0 §4.4), lengths and padding correct.
fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let pad = |v: &mut Vec<u8>, byte: u8| {
        while !v.len().is_multiple_of(4) {
            v.push(byte);
        }
    };
    let mut body = Vec::new();
    let mut j = json.to_vec();
    pad(&mut j, b' ');
    body.extend_from_slice(&(j.len() as u32).to_le_bytes());
    body.extend_from_slice(b"JSON");
    body.extend_from_slice(&j);
    if let Some(bin) = bin {
        let mut b = bin.to_vec();
        pad(&mut b, 0);
        body.extend_from_slice(&(b.len() as u32).to_le_bytes());
        body.extend_from_slice(b"BIN\0");
        body.extend_from_slice(&b);
    }
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + body.len()) as u32).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// Splits a GLB into its JSON and BIN chunks (for seeds only: they are well formed).
fn split_glb(bytes: &[u8]) -> Option<(Vec<u8>, Option<Vec<u8>>)> {
    let u32_at = |at: usize| -> Option<usize> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let json_len = u32_at(12)?;
    let json = bytes.get(20..20 + json_len)?.to_vec();
    let at = 20 + json_len;
    let bin = u32_at(at).and_then(|n| bytes.get(at + 8..at + 8 + n).map(<[u8]>::to_vec));
    Some((json, bin))
}

/// A small scene with everything the loader reads: positions, normals, u8/u16/u32 indices,
/// strips and fans, a sparse accessor, an interleaved view, two materials, a camera, a node
/// hierarchy with TRS and matrix transforms. Its buffer is a data URI (or, for the .glb, the
/// BIN chunk).
fn generated_scene() -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let f = |v: &mut Vec<u8>, xs: &[f32]| xs.iter().for_each(|x| v.extend(x.to_le_bytes()));
    // 0..48: four positions of a quad; 48..96: four normals.
    f(&mut bin, &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    f(&mut bin, &[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]);
    // 96..102: u8 indices, 104..116: u16, 116..140: u32.
    bin.extend([0u8, 1, 2, 0, 2, 3, 0, 0]);
    [0u16, 1, 2, 0, 2, 3]
        .iter()
        .for_each(|i| bin.extend(i.to_le_bytes()));
    [0u32, 1, 2, 0, 2, 3]
        .iter()
        .for_each(|i| bin.extend(i.to_le_bytes()));
    // 140..144: sparse index 1 (u32); 144..156: its value.
    bin.extend(1u32.to_le_bytes());
    f(&mut bin, &[0.5, 0.5, 0.5]);
    let json = json!({
        "asset": {"version": "2.0", "generator": "irr fuzz seed"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": 3, "color": [1, 0.5, 0.25], "range": 10},
            {"type": "spot", "intensity": 5, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.7}},
            {"type": "directional", "intensity": 1.5, "name": "sun"}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"children": [1, 2], "translation": [0, 0, -2], "rotation": [0, 0, 0, 1], "scale": [1, 1, 1],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "extras": [1],
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"mesh": 1, "scale": [-1, 1, 1]},
            {"camera": 0, "translation": [0.5, 0.5, 2], "extensions": {"KHR_lights_punctual": {"light": 2}}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01, "zfar": 100, "aspectRatio": 1.5}}],
        "meshes": [
            {"primitives": [
                {"attributes": {"POSITION": 0, "NORMAL": 1, "_EXTRA": 1}, "indices": 2, "material": 0},
                {"attributes": {"POSITION": 0}, "indices": 3, "mode": 5, "material": 1},
                {"attributes": {"POSITION": 0}, "indices": 4, "mode": 6}
            ]},
            {"primitives": [{"attributes": {"POSITION": 5}, "material": 0}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.7, 0.6, 1], "metallicFactor": 0},
             "emissiveFactor": [1, 1, 1], "doubleSided": true,
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3}}},
            {"pbrMetallicRoughness": {"metallicFactor": 0}}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5121, "count": 6, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 4, "componentType": 5125, "count": 6, "type": "SCALAR"},
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "sparse": {"count": 1, "indices": {"bufferView": 5, "componentType": 5125},
                        "values": {"bufferView": 6}}}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6},
            {"buffer": 0, "byteOffset": 104, "byteLength": 12},
            {"buffer": 0, "byteOffset": 116, "byteLength": 24},
            {"buffer": 0, "byteOffset": 140, "byteLength": 4},
            {"buffer": 0, "byteOffset": 144, "byteLength": 12}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    (json, bin)
}

fn seeds() -> Vec<Seed> {
    let assets = workspace().join("assets");
    let mut out = Vec::new();
    for name in ["cornell-box.gltf", "ao-plane.gltf", "disk-light.gltf"] {
        out.push(Seed {
            name: name.to_string(),
            bytes: read(&assets.join(name)),
            glb: false,
        });
    }
    out.push(Seed {
        name: "furnace.glb".to_string(),
        bytes: read(&assets.join("furnace.glb")),
        glb: true,
    });
    let (mut json, bin) = generated_scene();
    let text = |j: &Value| serde_json::to_vec(j).unwrap_or_default();
    out.push(Seed {
        name: "generated.glb".to_string(),
        bytes: glb(&text(&json), Some(&bin)),
        glb: true,
    });
    json["buffers"][0]["uri"] =
        format!("data:application/octet-stream;base64,{}", base64(&bin)).into();
    out.push(Seed {
        name: "generated.gltf".to_string(),
        bytes: text(&json),
        glb: false,
    });
    json["buffers"][0]["uri"] = "cornell-box.bin".into();
    json["buffers"][0]["byteLength"] = 156.into();
    out.push(Seed {
        name: "generated-external.gltf".to_string(),
        bytes: text(&json),
        glb: false,
    });
    out
}

// ---------------------------------------------------------------------------------------------
// Mutations.

/// Values that have broken parsers: boundaries of integer widths, huge counts, wrong types,
/// hostile URIs. `like` biases the choice toward the type of the value it replaces, so most
/// edits pass the schema and reach the loader's own checks.
fn interesting_value(rng: &mut Rng, like: &Value) -> Value {
    let kind = match like {
        Value::Number(n) if rng.below(4) != 0 => {
            if n.is_f64() && rng.below(2) == 0 {
                2
            } else {
                rng.below(2)
            }
        }
        Value::String(_) if rng.below(4) != 0 => 3,
        _ => rng.below(6),
    };
    match kind {
        0 => json!(*rng.pick(&[
            0u64,
            1,
            2,
            3,
            4,
            5,
            6,
            7,
            127,
            128,
            255,
            256,
            4095,
            65535,
            65536,
            (1 << 31) - 1,
            1 << 31,
            (1 << 32) - 1,
            1 << 32,
            1 << 33,
            100_000_000,
            1 << 28,
            (1 << 53) + 1,
            u64::MAX,
            5120,
            5121,
            5122,
            5123,
            5125,
            5126,
            34962,
        ])),
        1 => json!(*rng.pick(&[-1i64, -2, i64::MIN, -(1 << 31), -(1 << 53)])),
        2 => json!(*rng.pick(&[
            0.5f64, -0.0, 1e300, -1e300, 1e-300, 3.4e38, 1e18, 1e19, 6.5, 3.5
        ])),
        3 => json!(
            rng.pick(&[
                "",
                "../cornell-box.bin",
                "/etc/passwd",
                "%2e%2e/%2e%2e/etc/passwd",
                "/dev/zero",
                "/dev/urandom",
                "/proc/self/environ",
                "cornell-box.bin",
                ".",
                "..",
                "%",
                "%zz",
                "%ff%fe",
                "data:",
                "data:application/octet-stream;base64,",
                "data:application/octet-stream;base64,AAAA====",
                "data:application/octet-stream;base64,AAECAwQFBgcICQoLDA0ODw==",
                "data:text/plain,abc",
                "http://example.com/x.bin",
                "file:///etc/passwd",
                "perspective",
                "orthographic",
                "SCALAR",
                "VEC3",
                "MAT4",
                "BLEND",
                "MASK",
                "2.0",
                "1.0",
                "3.0",
                "\u{1b}[2J\u{7}",
                "POSITION",
                "_X",
                "KHR_draco_mesh_compression",
            ])
            .to_string()
        ),
        4 => match rng.below(5) {
            0 => Value::Null,
            1 => json!(true),
            2 => json!([]),
            3 => json!({}),
            _ => json!([1]),
        },
        _ => match rng.below(6) {
            0 => json!({"count": rng.next() % 8, "indices": {"bufferView": rng.next() % 8,
                        "componentType": *rng.pick(&[5121, 5123, 5125, 5126, 5120])},
                        "values": {"bufferView": rng.next() % 8}}),
            1 => json!({"type": "orthographic", "perspective": {"yfov": 0.5, "znear": 0.1}}),
            2 => {
                json!({"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 2, "znear": 1}})
            }
            3 => json!({"POSITION": rng.next() % 12, "NORMAL": rng.next() % 12}),
            4 => json!([0, 1, 2, 3, 0, 0, 0, 1]),
            _ => json!({"children": [0]}),
        },
    }
}

/// A random spot in the JSON tree: the path of keys and indices to it.
fn random_path(root: &Value, rng: &mut Rng) -> Vec<PathStep> {
    let mut path = Vec::new();
    let mut node = root;
    loop {
        // Stop here with probability 1/8, or when there is nowhere deeper to go (most edits hit
        // leaves, and keep their type).
        let next = match node {
            Value::Object(map) if !map.is_empty() && rng.below(8) != 0 => {
                let k = rng.below(map.len());
                map.iter()
                    .nth(k)
                    .map(|(key, v)| (PathStep::Key(key.clone()), v))
            }
            Value::Array(items) if !items.is_empty() && rng.below(8) != 0 => {
                let i = rng.below(items.len());
                Some((PathStep::Index(i), &items[i]))
            }
            _ => None,
        };
        match next {
            Some((step, child)) => {
                path.push(step);
                node = child;
            }
            None => return path,
        }
    }
}

#[derive(Clone, Debug)]
enum PathStep {
    Key(String),
    Index(usize),
}

fn at_mut<'v>(root: &'v mut Value, path: &[PathStep]) -> Option<&'v mut Value> {
    let mut node = root;
    for step in path {
        node = match step {
            PathStep::Key(k) => node.get_mut(k.as_str())?,
            PathStep::Index(i) => node.get_mut(*i)?,
        };
    }
    Some(node)
}

/// One edit of the JSON tree.
fn mutate_json(root: &mut Value, rng: &mut Rng) {
    // Somewhere below the root (replacing the whole document tests only the schema's first
    // line).
    let mut path = random_path(root, rng);
    for _ in 0..4 {
        if !path.is_empty() {
            break;
        }
        path = random_path(root, rng);
    }
    let choice = rng.below(10);
    // Edits of the parent (remove a member, duplicate an element) need the path's last step.
    if choice < 2
        && let Some((last, parent_path)) = path.split_last()
        && let Some(parent) = at_mut(root, parent_path)
    {
        match (parent, last) {
            (Value::Object(map), PathStep::Key(k)) => {
                map.remove(k);
            }
            (Value::Array(items), PathStep::Index(i)) => {
                if choice == 0 {
                    items.remove(*i);
                } else {
                    let copy = items[*i].clone();
                    items.push(copy);
                }
            }
            _ => {}
        }
        return;
    }
    let Some(node) = at_mut(root, &path) else {
        return;
    };
    match (choice, &mut *node) {
        // Add a member with a well-known glTF name to an object.
        (2, Value::Object(map)) => {
            let key = *rng.pick(&[
                "sparse",
                "bufferView",
                "byteStride",
                "byteOffset",
                "count",
                "camera",
                "children",
                "mesh",
                "matrix",
                "extras",
                "extensions",
                "uri",
                "byteLength",
                "indices",
                "mode",
                "type",
                "componentType",
                "perspective",
                "orthographic",
                "scene",
            ]);
            map.insert(key.to_string(), interesting_value(rng, &Value::Null));
        }
        // Nudge a number.
        (3, Value::Number(n)) => {
            let v = n.as_f64().unwrap_or(0.0);
            *node = json!(match rng.below(4) {
                0 => v + 1.0,
                1 => v - 1.0,
                2 => v * 2.0,
                _ => -v,
            });
        }
        _ => {
            let value = interesting_value(rng, node);
            *node = value;
        }
    }
}

/// Byte-level mutations.
fn mutate_bytes(bytes: &mut Vec<u8>, rng: &mut Rng) {
    if bytes.is_empty() {
        bytes.push(rng.next() as u8);
        return;
    }
    let n = bytes.len();
    match rng.below(7) {
        0 => {
            let i = rng.below(n);
            bytes[i] ^= 1 << rng.below(8);
        }
        1 => {
            let i = rng.below(n);
            bytes[i] = *rng.pick(&[0u8, 0xff, 0x7f, 0x80, b'"', b'{', b'[', b'9', b'-', b'\\']);
        }
        2 => bytes.truncate(rng.below(n)),
        3 => {
            // Overwrite 4 bytes with an interesting little-endian u32 (GLB lengths, counts).
            let i = rng.below(n);
            let v: u32 = *rng.pick(&[0, 1, 3, 4, 12, 20, 0x7fff_ffff, 0xffff_ffff, 0x8000_0000]);
            for (k, b) in v.to_le_bytes().into_iter().enumerate() {
                if let Some(slot) = bytes.get_mut(i + k) {
                    *slot = b;
                }
            }
        }
        4 => {
            let i = rng.below(n);
            let len = rng.below(16).min(n - i);
            bytes.drain(i..i + len);
        }
        5 => {
            let i = rng.below(n);
            let len = rng.below(32).min(n - i);
            let copy = bytes[i..i + len].to_vec();
            let at = rng.below(n);
            bytes.splice(at..at, copy);
        }
        _ => {
            let i = rng.below(n + 1);
            let extra: Vec<u8> = (0..rng.below(8) + 1).map(|_| rng.next() as u8).collect();
            bytes.splice(i..i, extra);
        }
    }
}

/// Case `k`: a seed and 1–4 mutations, the JSON edits applied to its parsed tree (and the GLB
/// rebuilt around them), the byte edits to the file.
fn gltf_case(seeds: &[Seed], seed: u64, k: u64) -> (String, Vec<u8>, bool) {
    let mut rng = Rng::new(seed, k);
    let s = rng.pick(seeds).clone();
    let (mut json, bin) = if s.glb {
        match split_glb(&s.bytes) {
            Some((j, b)) => (j, b),
            None => (s.bytes.clone(), None),
        }
    } else {
        (s.bytes.clone(), None)
    };
    // Mostly edits of the JSON tree (a byte edit of JSON text usually just breaks the syntax);
    // one to three of them, fewer more often, so many cases still load and reach deep code.
    let edits = 1 + usize::from(rng.below(3) == 0) + usize::from(rng.below(6) == 0);
    let structural = rng.below(4) != 0;
    if structural && let Ok(mut tree) = serde_json::from_slice::<Value>(&json) {
        for _ in 0..edits {
            mutate_json(&mut tree, &mut rng);
        }
        json = serde_json::to_vec(&tree).unwrap_or(json);
    }
    let mut bytes = if s.glb {
        glb(&json, bin.as_deref())
    } else {
        json
    };
    if !structural || rng.below(8) == 0 {
        for _ in 0..edits {
            mutate_bytes(&mut bytes, &mut rng);
        }
    }
    (s.name, bytes, s.glb)
}

/// What one case did.
struct Outcome {
    /// The panic message, if it panicked.
    panic: Option<String>,
    /// The kind of refusal, if the loader refused it: the error's first words after the file.
    refused: Option<String>,
    took: Duration,
}

/// The tiny render a fuzzed scene or cache gets: 4×4 pixels, 1 sample, one thread.
const TINY: RenderSettings = RenderSettings {
    width: 4,
    height: 4,
    spp: 1,
    seed: 1,
    threads: 1,
};

/// The irradiance cache's settings for a tiny render: the smallest gathers.
fn tiny_cache() -> IcSettings {
    IcSettings {
        strata_m: 2,
        strata_n: 4,
        // A light cache as small as the image (its construction still runs in every case).
        light_cache_paths: 1024,
        ..IcSettings::default()
    }
}

/// Renders a loaded scene as `irr` would, tiny, with the path tracer and with the irradiance
/// cache (its construction passes included). Panics are the caller's to catch.
fn render_tiny(loaded: &irr_render::LoadedScene) {
    let camera = loaded.camera_for(TINY.width, TINY.height);
    let path = PathTracer::new(irr_render::PathSettings::default());
    let _ = render(&loaded.scene, &camera, &path, &TINY, false);
    if let Ok(mut ic) = IrradianceCacheIntegrator::new(tiny_cache()) {
        irr_render::Integrator::preprocess(&mut ic, &loaded.scene);
        if build_cache(&loaded.scene, &camera, &mut ic, &TINY, false, false).is_ok() {
            let _ = render(&loaded.scene, &camera, &ic, &TINY, false);
        }
    }
}

/// Loads `bytes` as a scene (with the Cornell box's .bin beside it, for URIs that name it) and
/// renders what loads ([`render_tiny`]), inside `catch_unwind`.
fn run_gltf(dir: &Path, bytes: &[u8], glb: bool) -> Outcome {
    let path = dir.join(if glb { "case.glb" } else { "case.gltf" });
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    let started = Instant::now();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
        match irr_render::load_scene(&path) {
            Ok(loaded) => {
                render_tiny(&loaded);
                None
            }
            Err(e) => {
                // Every refusal is one printable line that names the file.
                let m = e.to_string();
                assert!(!m.contains('\n'), "a multi-line error: {m:?}");
                assert!(
                    m.contains("case.gl"),
                    "an error that does not name the file: {m}"
                );
                assert!(
                    !m.chars().any(|c| c.is_control()),
                    "an error with control characters: {m:?}"
                );
                let after = m.split_once(": ").map_or(m.as_str(), |(_, rest)| rest);
                let after = after
                    .strip_prefix("not a valid glTF 2.0 file: ")
                    .unwrap_or(after);
                if std::env::var_os("IRR_FUZZ_DEBUG").is_some() {
                    eprintln!("{after}");
                }
                Some(after.chars().take(36).collect())
            }
        }
    }));
    let took = started.elapsed();
    match result {
        Ok(refused) => Outcome {
            panic: None,
            refused,
            took,
        },
        Err(p) => Outcome {
            panic: Some(panic_message(&*p)),
            refused: None,
            took,
        },
    }
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "a panic".to_string())
}

/// Keeps a failing case and returns the line that reports it.
fn keep(kind: &str, ext: &str, bytes: &[u8], why: &str) -> String {
    let dir = crash_dir();
    let _ = std::fs::create_dir_all(&dir);
    let hash = bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    let path = dir.join(format!("{kind}-{hash:016x}.{ext}"));
    let _ = std::fs::write(&path, bytes);
    format!(
        "{why}; the case is in {} (replay: IRR_FUZZ_REPLAY={} cargo test -p irr-tests --test it fuzz; keep it in tests/fuzz-corpus/{kind}/ once fixed)",
        path.display(),
        path.display()
    )
}

fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // URIs that name the Cornell box's buffer find it.
    let _ = std::fs::copy(
        workspace().join("assets/cornell-box.bin"),
        d.path().join("cornell-box.bin"),
    );
    d
}

#[test]
fn gltf_loader_survives_mutated_files() {
    let seeds = seeds();
    let dir = scratch();
    let (seed, iters) = (base_seed(), iterations());
    let started = Instant::now();
    let mut failures = Vec::new();
    let mut refused = 0u64;
    let mut kinds = std::collections::BTreeMap::<String, u64>::new();
    for k in 0..iters {
        let (name, bytes, glb) = gltf_case(&seeds, seed, k);
        let outcome = run_gltf(dir.path(), &bytes, glb);
        let ext = if glb { "glb" } else { "gltf" };
        if let Some(p) = outcome.panic {
            failures.push(keep(
                "gltf",
                ext,
                &bytes,
                &format!("case {k} (from {name}) panicked: {p}"),
            ));
        } else if outcome.took > SLOW {
            failures.push(keep(
                "gltf",
                ext,
                &bytes,
                &format!("case {k} (from {name}) took {:?}", outcome.took),
            ));
        }
        if let Some(kind) = outcome.refused {
            refused += 1;
            *kinds.entry(kind).or_default() += 1;
        }
        if failures.len() >= 10 {
            break;
        }
    }
    eprintln!(
        "glTF fuzzer: {iters} executions (seed {seed}), {} loaded, {refused} refused, {} failing, {:.1} s",
        iters - refused,
        failures.len(),
        started.elapsed().as_secs_f64()
    );
    let mut kinds: Vec<(u64, String)> = kinds.into_iter().map(|(k, n)| (n, k)).collect();
    kinds.sort_by(|a, b| b.cmp(a));
    for (n, kind) in kinds.iter().take(12) {
        eprintln!("  {n:>8}  {kind}…");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The mutations must leave some files loadable, or they test little beyond the parser.
    assert!(refused < iters, "every case was refused");
}

// ---------------------------------------------------------------------------------------------
// The cache reader.

/// The fingerprint the cache fuzzer's files carry (and its reader expects).
const FINGERPRINT: u64 = 42;

/// A cache file as `irr --cache` writes it: the Cornell box's records at `size`² pixels.
fn cache_seed(cornell: &irr_render::LoadedScene, size: u32) -> Vec<u8> {
    let settings = RenderSettings {
        width: size,
        height: size,
        ..TINY
    };
    let camera = cornell.camera_for(size, size);
    let mut ic = IrradianceCacheIntegrator::new(tiny_cache()).unwrap_or_else(|e| panic!("{e}"));
    irr_render::Integrator::preprocess(&mut ic, &cornell.scene);
    build_cache(&cornell.scene, &camera, &mut ic, &settings, false, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let dir = scratch();
    let path = dir.path().join("seed.irrc");
    irr_render::write_cache_file(&path, FINGERPRINT, &ic).unwrap_or_else(|e| panic!("{e}"));
    read(&path)
}

/// FNV-1a 64 (irr-cache's checksum, the last 8 bytes of its part).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// Where a view's cache file keeps its level count (after the magic, the fingerprint, the
/// origin, the shard index and count, the camera and the key frame count, 0).
const LEVELS_AT: usize = 56;

/// Where `bytes` keep their level count: after the header and its key frames' times (a key
/// frame count that does not fit the file counts as none).
fn levels_at(bytes: &[u8]) -> usize {
    let k = bytes
        .get(48..56)
        .and_then(|b| b.try_into().ok())
        .map_or(0, u64::from_le_bytes);
    usize::try_from(k)
        .ok()
        .and_then(|k| k.checked_mul(8))
        .filter(|&t| t <= bytes.len())
        .map_or(LEVELS_AT, |t| LEVELS_AT + t)
}

/// Where irr-cache's part of the first level lies in a cache file (after the 64-byte header,
/// the level's record count, `ENTRY_BYTES` per record and the part's length), if the counts still
/// fit.
fn inner_part(bytes: &[u8]) -> Option<std::ops::Range<usize>> {
    let word = |at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?))
    };
    let at = levels_at(bytes);
    let n = word(at + 8)?;
    let size_at = usize::try_from(
        n.checked_mul(irr_render::ENTRY_BYTES as u64)?
            .checked_add(at as u64 + 16)?,
    )
    .ok()?;
    let start = size_at.checked_add(8)?;
    let end = start.checked_add(usize::try_from(word(size_at)?).ok()?)?;
    (start + 28 + 8 <= end && end <= bytes.len().checked_sub(8)?).then_some(start..end)
}

fn cache_case(seeds: &[Vec<u8>], seed: u64, k: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed ^ 0xCAC4E, k);
    let mut bytes = rng.pick(seeds).clone();
    for _ in 0..rng.below(4) + 1 {
        let inner = inner_part(&bytes);
        let levels = levels_at(&bytes);
        let choice = rng.below(4);
        if choice == 0 && bytes.len() >= levels + 16 {
            // A count: of the file's levels, of the first level's records, of irr-cache's
            // part, of the key frames or of the shards (or the origin): a huge, zero or
            // off-by-one value.
            let at = match (&inner, rng.below(5)) {
                (Some(r), 0) => r.start + 20,
                (_, 1) => levels + 8,
                (_, 2) => 48,
                (_, 3) => 16 + 8 * rng.below(4),
                _ => levels,
            };
            let count = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap_or([0; 8]));
            let v = *rng.pick(&[
                0,
                1,
                count.wrapping_add(1),
                count.saturating_sub(1),
                u64::MAX,
                1 << 40,
                1 << 20,
            ]);
            bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
        } else if choice == 1 && bytes.len() > LEVELS_AT + 16 {
            // A float of a key frame's time, a leak-guard entry or a record: NaN, infinity,
            // negative, huge, zero.
            let at = LEVELS_AT + 4 * rng.below((bytes.len() - LEVELS_AT - 8) / 4);
            let v: f32 = *rng.pick(&[f32::NAN, f32::INFINITY, -1.0, 0.0, 1e38, -1e-40, f32::MAX]);
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        } else {
            mutate_bytes(&mut bytes, &mut rng);
        }
    }
    // Usually recompute the checksums (irr-cache's, then the whole file's), so the mutation
    // reaches the decoders behind them.
    if rng.below(4) != 0 {
        if let Some(r) = inner_part(&bytes) {
            let n = r.end - 8;
            let h = fnv1a(&bytes[r.start..n]);
            bytes[n..r.end].copy_from_slice(&h.to_le_bytes());
        }
        if bytes.len() >= 8 {
            let n = bytes.len() - 8;
            let h = irr_render::fingerprint(&[&bytes[..n]]);
            bytes[n..].copy_from_slice(&h.to_le_bytes());
        }
    }
    bytes
}

/// Reads `bytes` as `irr --cache` reads a cache file, and renders the Cornell box from every
/// cache it accepts, inside `catch_unwind`: the panic message, whether it was accepted, and the
/// time.
fn run_cache(
    cornell: &irr_render::LoadedScene,
    dir: &Path,
    bytes: &[u8],
) -> (Option<String>, bool, Duration) {
    let path = dir.join("case.irrc");
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    let started = Instant::now();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
        let settings = tiny_cache();
        let Ok(levels) = irr_render::read_cache_file(&path, FINGERPRINT, &settings, 1 << 24) else {
            return false;
        };
        let mut ic = IrradianceCacheIntegrator::new(settings).unwrap_or_else(|e| panic!("{e}"));
        irr_render::Integrator::preprocess(&mut ic, &cornell.scene);
        if ic.load_levels(levels).is_err() {
            return false;
        }
        let camera = cornell.camera_for(TINY.width, TINY.height);
        let _ = render(&cornell.scene, &camera, &ic, &TINY, false);
        true
    }));
    let took = started.elapsed();
    match result {
        Ok(ok) => (None, ok, took),
        Err(p) => (Some(panic_message(&*p)), false, took),
    }
}

fn cornell() -> irr_render::LoadedScene {
    irr_render::load_scene(&workspace().join("assets/cornell-box.gltf"))
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn cache_reader_survives_mutated_files() {
    let cornell = cornell();
    let dir = scratch();
    let seeds: Vec<Vec<u8>> = [1, 3, 8]
        .into_iter()
        .map(|size| cache_seed(&cornell, size))
        .collect();
    // The seeds themselves read back.
    for s in &seeds {
        assert!(
            run_cache(&cornell, dir.path(), s).1,
            "a cache file written by write_cache_file does not read back"
        );
    }
    let (seed, iters) = (base_seed(), 4 * iterations());
    let mut failures = Vec::new();
    let mut accepted = 0u64;
    let started = Instant::now();
    for k in 0..iters {
        let bytes = cache_case(&seeds, seed, k);
        let (panic, ok, took) = run_cache(&cornell, dir.path(), &bytes);
        accepted += u64::from(ok);
        if record_failure("cache", k, &bytes, (panic, took), &mut failures) {
            break;
        }
    }
    eprintln!(
        "cache fuzzer: {iters} executions (seed {seed}), {accepted} accepted, {} failing, {:.1} s",
        failures.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Keeps case `k` of a cache-file fuzzer (`kind`: its corpus folder) if it panicked or took
/// longer than `SLOW`; whether the run should stop (ten failures are enough to debug).
fn record_failure(
    kind: &str,
    k: u64,
    bytes: &[u8],
    (panic, took): (Option<String>, Duration),
    failures: &mut Vec<String>,
) -> bool {
    if let Some(p) = panic {
        failures.push(keep(
            kind,
            "irrc",
            bytes,
            &format!("case {k} panicked: {p}"),
        ));
    } else if took > SLOW {
        failures.push(keep(
            kind,
            "irrc",
            bytes,
            &format!("case {k} took {took:?}"),
        ));
    }
    failures.len() >= 10
}

/// Shard files as `irr --shards 2 --shard I` writes them: the Cornell box's records from two
/// key views (the camera and the camera moved 10 cm), a shard each.
fn shard_seeds(cornell: &irr_render::LoadedScene) -> Vec<Vec<u8>> {
    let settings = RenderSettings {
        width: 6,
        height: 6,
        ..TINY
    };
    let rest = cornell.camera_for(settings.width, settings.height);
    let moved = irr_render::Camera {
        position: rest.position + rest.right * 0.1,
        ..rest
    };
    let views = [rest, moved];
    let keys = irr_render::KeyFrames {
        camera: None,
        times: vec![0.0, 1.0],
    };
    (0..2)
        .map(|index| {
            let mut ic =
                IrradianceCacheIntegrator::new(tiny_cache()).unwrap_or_else(|e| panic!("{e}"));
            irr_render::Integrator::preprocess(&mut ic, &cornell.scene);
            irr_render::build_cache_shard(
                &cornell.scene,
                &views,
                keys.shard(index, 2),
                &mut ic,
                &settings,
                false,
                false,
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let origin = irr_render::CacheOrigin::Shard {
                index,
                shards: 2,
                keys: keys.clone(),
            };
            irr_render::CacheContents::of(&ic, FINGERPRINT, origin)
                .and_then(|c| c.encode())
                .unwrap_or_else(|e| panic!("{e}"))
        })
        .collect()
}

/// `irr cache merge` on two shard files, one of them mutated (`cache_case`'s mutations, the
/// checksums usually recomputed), then the merged file read back as the frames read it: no
/// panic, no case slower than `SLOW`, and the unmutated pair merges and files.
#[test]
fn shard_merge_survives_mutated_files() {
    let cornell = cornell();
    let seeds = shard_seeds(&cornell);
    let merge = |a: &[u8], b: &[u8]| -> bool {
        let (Ok(a), Ok(b)) = (
            irr_render::CacheContents::decode(a),
            irr_render::CacheContents::decode(b),
        ) else {
            return false;
        };
        let Ok((merged, _)) =
            irr_render::merge_shards(vec![("a.irrc".into(), a), ("b.irrc".into(), b)])
        else {
            return false;
        };
        let Ok(bytes) = merged.encode() else {
            return false;
        };
        irr_render::CacheContents::decode(&bytes)
            .map_err(|e| e.to_string())
            .and_then(|c| c.file(&tiny_cache()))
            .is_ok()
    };
    assert!(
        merge(&seeds[0], &seeds[1]),
        "the shards as written do not merge"
    );
    let (seed, iters) = (base_seed(), 2 * iterations());
    let mut failures = Vec::new();
    let mut accepted = 0u64;
    for k in 0..iters {
        let which = (k % 2) as usize;
        let bytes = cache_case(&seeds[which..=which], seed ^ 0x5_4A2D, k);
        let started = Instant::now();
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
            if which == 0 {
                merge(&bytes, &seeds[1])
            } else {
                merge(&seeds[0], &bytes)
            }
        }));
        let took = started.elapsed();
        let panic = match result {
            Ok(ok) => {
                accepted += u64::from(ok);
                None
            }
            Err(p) => Some(panic_message(&*p)),
        };
        if record_failure("shard", k, &bytes, (panic, took), &mut failures) {
            break;
        }
    }
    eprintln!(
        "shard merge fuzzer: {iters} executions (seed {seed}), {accepted} accepted, {} failing",
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Replay: the kept corpus, and one file on request.

fn corpus_files(kind: &str) -> Vec<PathBuf> {
    let dir = workspace().join("tests/fuzz-corpus").join(kind);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|entries| entries.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.sort();
    files
}

#[test]
fn kept_corpus_replays_without_panics() {
    let dir = scratch();
    let cornell = cornell();
    let mut failures = Vec::new();
    let mut files = corpus_files("gltf");
    if let Ok(one) = std::env::var("IRR_FUZZ_REPLAY") {
        files.push(PathBuf::from(one));
    }
    let mut replayed = 0;
    for path in files {
        let bytes = read(&path);
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        replayed += 1;
        let failure = match ext {
            "irrc" => run_cache(&cornell, dir.path(), &bytes).0,
            "gltf" | "glb" => {
                let o = run_gltf(dir.path(), &bytes, ext == "glb");
                o.panic
                    .or_else(|| (o.took > SLOW).then(|| format!("took {:?}", o.took)))
            }
            _ => continue,
        };
        if let Some(f) = failure {
            failures.push(format!("{}: {f}", path.display()));
        }
    }
    for path in corpus_files("cache") {
        replayed += 1;
        if let Some(f) = run_cache(&cornell, dir.path(), &read(&path)).0 {
            failures.push(format!("{}: {f}", path.display()));
        }
    }
    eprintln!("replayed {replayed} kept fuzz cases");
    assert!(replayed > 0, "tests/fuzz-corpus/ is empty or missing");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
