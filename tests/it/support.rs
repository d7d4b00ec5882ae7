//! Helpers shared by the test modules.

use glam::Vec3;
use irr_geometry::TriangleMesh;
use irr_integrator::{Integrator, Scene};
use irr_render::{
    Camera, IcSettings, Image, IrradianceCacheIntegrator, PathSettings, PathTracer, RenderSettings,
    build_cache, render,
};
use std::path::{Path, PathBuf};

/// relMSE = mean over pixels and channels of (x − r)²/(r² + 0.01): the measure of the peer
/// figures in the issues and of `cargo xtask compare`.
pub fn rel_mse(a: &Image, b: &Image) -> f64 {
    let mut sum = 0.0;
    for (x, r) in a.pixels().iter().zip(b.pixels()) {
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            sum += (x - r).powi(2) / (r * r + 0.01);
        }
    }
    sum / (a.pixels().len() * 3) as f64
}

/// A quad as two triangles (counter-clockwise seen from the side `normal_hint` points to).
pub fn quad(corners: [Vec3; 4], material: u32, normal_hint: Vec3) -> TriangleMesh {
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    let indices = if n.dot(normal_hint) >= 0.0 {
        vec![[0, 1, 2], [0, 2, 3]]
    } else {
        vec![[0, 2, 1], [0, 3, 2]]
    };
    TriangleMesh {
        positions: corners.to_vec(),
        indices,
        normals: None,
        material_ids: vec![material; 2],
    }
}

/// An axis-aligned box [lo, hi] as six quads facing out: for each axis, the face at lo and the
/// face at hi, their corners in order around the face.
pub fn cuboid(lo: Vec3, hi: Vec3, material: u32) -> Vec<TriangleMesh> {
    let mut faces = Vec::with_capacity(6);
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [false, true] {
            let at = |a: bool, b: bool| {
                let mut c = lo;
                for (k, on) in [(axis, side), (u, a), (v, b)] {
                    c[k] = if on { hi[k] } else { lo[k] };
                }
                c
            };
            let mut outward = Vec3::ZERO;
            outward[axis] = if side { 1.0 } else { -1.0 };
            faces.push(quad(
                [
                    at(false, false),
                    at(true, false),
                    at(true, true),
                    at(false, true),
                ],
                material,
                outward,
            ));
        }
    }
    faces
}

/// Pixel means over a region, with the standard error of the mean from K independent renders.
pub fn region_mean(images: &[Image], region: &[(u32, u32)]) -> (f64, f64) {
    let means: Vec<f64> = images
        .iter()
        .map(|im| {
            region
                .iter()
                .map(|&(x, y)| f64::from(im.get(x, y).element_sum()) / 3.0)
                .sum::<f64>()
                / region.len() as f64
        })
        .collect();
    let k = means.len() as f64;
    let mean = means.iter().sum::<f64>() / k;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0);
    (mean, (var / k).sqrt())
}

/// The integrator with its cache built for `settings`.
pub fn built(
    scene: &Scene,
    camera: &Camera,
    ic: IcSettings,
    settings: &RenderSettings,
) -> IrradianceCacheIntegrator {
    let mut integrator = IrradianceCacheIntegrator::new(ic).unwrap_or_else(|e| panic!("{e}"));
    integrator.preprocess(scene);
    build_cache(
        scene,
        camera,
        &mut integrator,
        settings,
        ic.fill_samples,
        false,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    integrator
}

/// Builds the cache and renders: the image and the number of level-0 records.
pub fn ic_image(
    scene: &Scene,
    camera: &Camera,
    ic: IcSettings,
    settings: &RenderSettings,
) -> (Image, usize) {
    let integrator = built(scene, camera, ic, settings);
    let image = render(scene, camera, &integrator, settings, false)
        .unwrap_or_else(|e| panic!("{e}"))
        .image;
    let records = integrator.cache(0).map_or(0, |c| c.len());
    (image, records)
}

pub fn path_image(scene: &Scene, camera: &Camera, settings: &RenderSettings) -> Image {
    let pt = PathTracer::new(PathSettings::default());
    render(scene, camera, &pt, settings, false)
        .unwrap_or_else(|e| panic!("{e}"))
        .image
}

/// The indirect part alone (`li_split().indirect`) of the path tracer or of the cache: the part
/// the cache computes, free of the direct light's and the directly seen emitter's noise.
pub struct Indirect<'a> {
    pub path: Option<&'a PathTracer>,
    pub ic: Option<&'a IrradianceCacheIntegrator>,
}

impl Integrator for Indirect<'_> {
    fn name(&self) -> &'static str {
        "indirect"
    }
    fn li(
        &self,
        scene: &Scene,
        ray: &irr_geometry::Ray,
        dims: &mut irr_sampling::rng::Dimensions,
        rays: &mut irr_integrator::RayCounter,
    ) -> Vec3 {
        match (self.path, self.ic) {
            (Some(p), _) => p.li_split(scene, ray, dims, rays).indirect,
            (_, Some(c)) => c.li_split(scene, ray, dims, rays).indirect,
            _ => Vec3::ZERO,
        }
    }
}

/// The relative difference of two images' sums (all pixels and channels): a's mean bias
/// against b.
pub fn mean_bias(a: &Image, b: &Image) -> f64 {
    let sum = |im: &Image| {
        im.pixels()
            .iter()
            .map(|p| f64::from(p.element_sum()))
            .sum::<f64>()
    };
    (sum(a) - sum(b)) / sum(b)
}

/// The path tracer's indirect part at 2 × 1024 spp (seeds 91 and 92) and its own relMSE
/// (relMSE between the halves / 4).
pub fn indirect_reference(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
) -> (Image, f64) {
    let pt = PathTracer::new(PathSettings::default());
    let view = Indirect {
        path: Some(&pt),
        ic: None,
    };
    let half = |seed| {
        let s = RenderSettings {
            spp: 1024,
            seed,
            ..*settings
        };
        render(scene, camera, &view, &s, false)
            .unwrap_or_else(|e| panic!("{e}"))
            .image
    };
    let (a, b) = (half(91), half(92));
    let mean = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(x, y)| (*x + *y) * 0.5)
        .collect();
    let image =
        Image::from_pixels(settings.width, settings.height, mean).unwrap_or_else(|| panic!("size"));
    (image, rel_mse(&a, &b) / 4.0)
}

/// A loose and a tight setting's images over the same seeds (at least three), against a
/// reference with its own noise `reference_noise`: the relMSE (of the first seed's images)
/// falls by more than twice the noise, the tight image's own (relMSE between its second and
/// third seeds / 2) plus the reference's, since each of the two relMSEs compared carries it once;
/// and the mean bias over the seeds shrinks, or is within 3 standard errors of zero (that
/// mean's spread over the seeds / √k) where it cannot be told from zero. `label` names the
/// case in the printed figures and the failures.
pub fn assert_error_and_bias_fall(
    label: &str,
    (loose, tight): (&[Image], &[Image]),
    (reference, reference_noise): (&Image, f64),
) {
    let noise = rel_mse(&tight[1], &tight[2]) / 2.0 + reference_noise;
    let (e0, e1) = (rel_mse(&loose[0], reference), rel_mse(&tight[0], reference));
    let bias = |images: &[Image]| -> (f64, f64) {
        let b: Vec<f64> = images.iter().map(|i| mean_bias(i, reference)).collect();
        let k = b.len() as f64;
        let mean = b.iter().sum::<f64>() / k;
        let var = b.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0);
        (mean, (var / k).sqrt())
    };
    let ((b0, se0), (b1, se1)) = (bias(loose), bias(tight));
    println!(
        "{label}: loose relMSE {e0:.3e}, bias {:+.3} ± {:.3} %; tight relMSE {e1:.3e}, bias {:+.3} ± {:.3} %; noise {noise:.3e}",
        100.0 * b0,
        100.0 * se0,
        100.0 * b1,
        100.0 * se1
    );
    assert!(
        e1 + 2.0 * noise < e0,
        "{label}: the error did not fall beyond the noise ({e0:.3e} -> {e1:.3e}, noise {noise:.3e})"
    );
    assert!(
        b1.abs() < b0.abs() || b1.abs() < 3.0 * se1,
        "{label}: the bias did not shrink: {b0:+.4} -> {b1:+.4} (standard error {se1:.4})"
    );
}

/// The path of `name` in the workspace's assets/.
pub fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../assets")
        .join(name)
}

/// A temporary folder, removed when dropped.
pub fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
}

/// The bytes of `path` (panics naming it).
pub fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Writes `bytes` to `path` (panics naming it).
pub fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}
