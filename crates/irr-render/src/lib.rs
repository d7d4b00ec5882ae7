//! irr-render turns a glTF file into an image: it loads the scene, renders it through an
//! integrator in parallel tiles, and writes OpenEXR plus a PNG preview.
//!
//! # What it owns
//! - [`load_scene`]: a glTF file read by irr-scene's [`load_gltf`] (meshes, [`Material`]s and
//!   their textures, [`PunctualLight`]s, [`NamedCamera`]s, [`Warning`]s) assembled into the
//!   integrator's [`Scene`] (BVH, light sampler) as a [`LoadedScene`], with the camera to render
//!   it from ([`LoadedScene::camera_for`], [`Camera::framing`] when the file has none).
//! - [`render`] and [`RenderSettings`]: the film (box filter, row 0 at the top), tiles on a
//!   rayon pool (each tile hands the integrator its pixels' samples of one index as one batch,
//!   `Integrator::li_many`), the progress bar and the summary ([`RenderStats`]);
//!   [`render_with_aovs`] adds auxiliary images ([`Aov`]: albedo, normal, depth, and the
//!   colour's emitted, direct and indirect parts, and the indirect part's glossy share);
//!   [`pixel_samples`] replays one pixel;
//!   [`RenderSettings::image_size`] derives a missing width or height from the camera's aspect
//!   ratio.
//! - [`build_cache`]: the deterministic parallel passes that build an irradiance cache through an
//!   integrator's [`CacheBuilder`] (the pixel order and the threads are irr-render's; the
//!   records and their commit are the integrator's).
//! - [`denoise`]: Intel Open Image Denoise's `RT` filter on a render's colour with its albedo
//!   and normal, with the optional `denoise` feature ([`DENOISER`] says whether this build has
//!   it).
//! - [`write_exr_and_png`] and [`write_render`]: linear f32 OpenEXR (chromaticities, and for a
//!   render its AOVs and [`ExrMetadata`]) and an sRGB PNG preview, both written to temporary
//!   files and renamed into place; [`Image`] with [`Image::read_exr`].
//!
//! # What it must not know
//! How radiance is estimated: that is the [`Integrator`]'s business (irr-integrator). It never
//! looks inside an integrator and hands it nothing but the scene, the camera ray, the sample's
//! random numbers and a ray counter.
//!
//! # Example
//! ```
//! use irr_render::{load_scene, render, write_exr_and_png, Image, RenderSettings};
//! use irr_render::{AmbientOcclusion, AoSettings};
//!
//! # fn main() -> Result<(), irr_render::RenderError> {
//! let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
//! let loaded = load_scene(&assets.join("ao-plane.gltf"))?;
//! let settings = RenderSettings { width: 8, height: 8, spp: 2, ..RenderSettings::default() };
//! let camera = loaded.camera_for(settings.width, settings.height);
//! let ao = AmbientOcclusion::new(AoSettings::default());
//! let out = render(&loaded.scene, &camera, &ao, &settings, false)?;
//! // Nothing above the plane: every ambient-occlusion sample sees the sky.
//! assert!(out.image.pixels().iter().all(|p| *p == glam::Vec3::ONE));
//!
//! let dir = tempfile::tempdir().map_err(|e| irr_render::RenderError::Write {
//!     path: "tmp".into(),
//!     problem: e.to_string(),
//! })?;
//! let (exr, png) = write_exr_and_png(&out.image, &dir.path().join("plane.exr"), 0.0)?;
//! assert_eq!(Image::read_exr(&exr)?, out.image);
//! assert!(png.exists());
//! # Ok(())
//! # }
//! ```

mod aov;
mod cachefile;
mod denoise;
mod error;
mod image;
#[cfg(test)]
mod loaded_tests;
mod output;
mod passes;
mod render;

pub use aov::{Aov, AovImages, normalise_aovs};
pub use cachefile::{
    CacheContents, CacheOrigin, ENTRY_BYTES, KeyFrames, LevelRecords, MAX_KEY_FRAMES, MAX_SHARDS,
    MergeReport, check_fingerprint, fingerprint, merge_shards, read_cache_file, write_cache_file,
};
pub use denoise::{DENOISER, DENOISER_AOVS, NO_DENOISER, denoise};
pub use error::RenderError;
pub use image::Image;
pub use irr_geometry::OUTLIER_SPAN;
pub use irr_integrator::{
    AmbientOcclusion, AoSettings, BounceMode, CacheBuilder, CachedAmbientOcclusion, GradientMode,
    GuardRecord, IcSettings, Integrator, IrradianceCacheIntegrator, LeakGuard, Material,
    MetricKind, PathSettings, PathTracer, PunctualLight, RadiusStatistic, RayCounter, Scene,
};
pub use irr_scene::{
    Camera, CameraRay, LoadOptions, MAX_COORDINATE, MAX_IMAGE_SIDE, MAX_JSON_BYTES,
    MAX_SCENE_BYTES, NamedCamera, Projection, SceneData, Warning, animation, load_gltf,
    load_gltf_with,
};
pub use output::{
    ExrMetadata, check_exposure, check_output, check_output_file, remove_partial_outputs,
    remove_partial_outputs_on_signals, tone_map, write_exr_and_png, write_render,
};
pub use passes::{
    CacheBuildStats, LightCacheStats, PassStats, build_cache, build_cache_shard, build_light_cache,
    build_shared_cache, mark_records, pixel_spread,
};
pub use render::{
    DEFAULT_ASPECT_RATIO, MAX_DIMENSION, MAX_THREADS, RenderOutput, RenderSettings, RenderStats,
    TILE_SIZE, mean_of_samples, pixel_samples, raster_position, render, render_with_aovs,
};

use glam::Vec3;
use irr_geometry::Geometry;
use std::path::{Path, PathBuf};

/// A scene ready to render: the integrator's [`Scene`] (geometry with its BVH, materials and
/// their textures, emitting triangles and punctual lights; a black background, which the caller
/// may change with [`Scene::with_background`]), the file's cameras, and the warnings about what
/// the file uses that irr ignored.
#[derive(Debug)]
pub struct LoadedScene {
    /// The file it came from.
    pub path: PathBuf,
    /// Geometry, materials, emitters and lights.
    pub scene: Scene,
    /// The file's first perspective camera, if it has one.
    pub camera: Option<Camera>,
    /// Every perspective camera of the file, in depth-first order of the scene's nodes.
    pub cameras: Vec<NamedCamera>,
    /// What the file uses that irr ignored, one entry per feature, and other notes (no
    /// emitter, degenerate triangles dropped).
    pub warnings: Vec<Warning>,
    /// The box a default view frames: the bounds of the scene's triangles without those that
    /// alone stretch them, such as a far ground plane ([`irr_geometry::Geometry::core_bounds`]).
    pub bounds: (Vec3, Vec3),
    /// The digest of every byte the scene was read from ([`SceneData::digest`]).
    pub digest: u64,
    /// The animation channels that move meshes or lights ([`SceneData::animated_content`]).
    pub animated_content: usize,
}

impl LoadedScene {
    /// The camera to render a `width` × `height` image with: the file's, or, if it has none,
    /// [`Camera::framing`] the scene's bounds at that aspect ratio.
    pub fn camera_for(&self, width: u32, height: u32) -> Camera {
        self.camera.unwrap_or_else(|| {
            Camera::framing(
                self.bounds.0,
                self.bounds.1,
                width as f32 / height.max(1) as f32,
            )
        })
    }

    /// The file's camera number `index` (`--camera`; the first when `None`), or `None` for a
    /// file without cameras when no number was asked for (then [`Camera::framing`] frames the
    /// scene). A number the file does not have is an error that says how many it has.
    pub fn choose_camera(&self, index: Option<usize>) -> Result<Option<Camera>, RenderError> {
        let Some(i) = index else {
            return Ok(self.cameras.first().map(|c| c.camera));
        };
        if let Some(c) = self.cameras.get(i) {
            return Ok(Some(c.camera));
        }
        // At most ten listed: a file may hold thousands.
        let listed: Vec<String> = self
            .cameras
            .iter()
            .take(10)
            .enumerate()
            .map(|(n, c)| format!("{n}: {}", c.describe()))
            .collect();
        let more = if self.cameras.len() > listed.len() {
            ", …"
        } else {
            ""
        };
        let problem = match self.cameras.len() {
            0 => format!(
                "{} has no perspective camera (irr frames the scene's bounds without one)",
                self.path.display()
            ),
            n => format!(
                "{} has {n} perspective camera{}, numbered from 0 ({}{more})",
                self.path.display(),
                if n == 1 { "" } else { "s" },
                listed.join(", ")
            ),
        };
        Err(RenderError::Setting {
            option: "--camera",
            problem: format!("there is no camera {i}: {problem}"),
        })
    }

    /// [`LoadedScene::choose_camera`] at `time` seconds of its animation (`None`: the rest
    /// pose): a camera whose node or a node above it is animated is placed by its path at that
    /// time; any other keeps its place.
    pub fn choose_camera_at(
        &self,
        index: Option<usize>,
        time: Option<f64>,
    ) -> Result<Option<Camera>, RenderError> {
        let rest = self.choose_camera(index)?;
        let (Some(t), Some(path)) = (time, self.camera_path(index)) else {
            return Ok(rest);
        };
        path.camera_at(t as f32)
            .map(Some)
            .ok_or_else(|| RenderError::Setting {
                option: "--frame",
                problem: format!(
                    "at {t} s the camera's animation collapses its view direction ({})",
                    self.path.display()
                ),
            })
    }

    /// The path of camera `index` (the first when `None`), if an animation moves it.
    pub fn camera_path(&self, index: Option<usize>) -> Option<&animation::CameraPath> {
        self.cameras.get(index.unwrap_or(0))?.path.as_ref()
    }

    /// A note when `camera` (one of the file's) gives an `aspectRatio` that differs from the
    /// image's (irr follows the image; the vertical field of view is kept).
    pub fn aspect_note(&self, camera: &Camera, width: u32, height: u32) -> Option<String> {
        let file = camera.aspect_ratio_in_file?;
        let image = width as f32 / height.max(1) as f32;
        // Relative difference above 0.1 %: beyond the rounding of any sensible file value.
        ((file - image).abs() > 1e-3 * image).then(|| {
            format!(
                "{}: the camera's aspectRatio {file} differs from the image's {image} ({width}×{height}); irr keeps yfov and uses the image's",
                self.path.display()
            )
        })
    }
}

/// Loads a glTF 2.0 file and builds everything the integrators need (BVH, light sampler).
///
/// Errors name the file and the problem in one line; warnings (ignored features, no emitter,
/// degenerate triangles dropped) are returned in [`LoadedScene::warnings`], never printed.
pub fn load_scene(path: &Path) -> Result<LoadedScene, RenderError> {
    load_scene_with(path, &LoadOptions::default())
}

/// [`load_scene`] with [`LoadOptions`] (the folder buffer files may be read from).
pub fn load_scene_with(path: &Path, options: &LoadOptions) -> Result<LoadedScene, RenderError> {
    let data = load_gltf_with(path, options)?;
    data.check_memory()?;
    let SceneData {
        mut meshes,
        prototypes,
        instances,
        materials,
        textures,
        tex_coords,
        colours,
        alphas,
        tangents,
        camera,
        cameras,
        lights,
        mut warnings,
        digest,
        animated_content,
        ..
    } = data;
    // Texture coordinates by attribute id (the world meshes', then the prototypes'), before the
    // meshes are consumed (degenerate triangles the build drops have none).
    let world = meshes.len();
    meshes.extend(prototypes);
    let tex_coords = irr_scene::tex_coords_by_id(&meshes, &materials, &tex_coords)
        .map_err(|e| RenderError::scene(path, e))?;
    let colours =
        irr_scene::attribute_by_id(&meshes, &colours).map_err(|e| RenderError::scene(path, e))?;
    let tangents =
        irr_scene::attribute_by_id(&meshes, &tangents).map_err(|e| RenderError::scene(path, e))?;
    let alphas =
        irr_scene::attribute_by_id(&meshes, &alphas).map_err(|e| RenderError::scene(path, e))?;
    // The meshes are consumed: each part is freed as soon as the BVH's leaves hold it, so a
    // large scene is never in memory twice.
    let prototypes = meshes.split_off(world);
    let geometry = Geometry::build_instanced(meshes, prototypes, &instances)
        .map_err(|e| RenderError::scene(path, e.to_string()))?;
    let report = *geometry.report();
    if report.dropped_degenerate > 0 {
        warnings.push(Warning {
            file: path.to_path_buf(),
            feature: "degenerate".to_string(),
            count: report.dropped_degenerate,
            message: format!(
                "{} degenerate (zero-area) triangle{} dropped",
                report.dropped_degenerate,
                if report.dropped_degenerate == 1 {
                    ""
                } else {
                    "s"
                }
            ),
        });
    }
    if report.dropped_instances > 0 {
        let n = report.dropped_instances;
        warnings.push(Warning {
            file: path.to_path_buf(),
            feature: "singular-placement".to_string(),
            count: n,
            message: format!(
                "{n} placement{} of a repeated mesh dropped: its transform is not invertible (a zero scale)",
                if n == 1 { "" } else { "s" }
            ),
        });
    }
    let bounds = geometry.core_bounds();
    let scene = Scene::with_textures(geometry, materials, textures, tex_coords)
        .and_then(|s| s.with_vertex_colours(colours))
        .and_then(|s| s.with_tangents(tangents))
        .and_then(|s| s.with_vertex_alphas(alphas))
        .and_then(|s| s.with_lights(lights))
        .map_err(|e| RenderError::scene(path, e.to_string()))?;
    Ok(LoadedScene {
        path: path.to_path_buf(),
        scene,
        camera,
        cameras,
        warnings,
        bounds,
        digest,
        animated_content,
    })
}
