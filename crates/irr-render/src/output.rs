//! Writing a render: an OpenEXR file of linear radiance (f32 RGB, lossless) and, beside it with
//! the same stem, a PNG preview. Both are written to temporary files in the destination folder
//! and renamed into place only once both are complete, so a failed or interrupted write never
//! leaves a half-written file and never destroys the previous output.
//!
//! # The OpenEXR file
//! One part, scan lines from the top, ZIP compression (lossless), every channel 32-bit float:
//! `R`, `G`, `B` (the colour) and the AOVs asked for, named as the module `aov` describes
//! (`albedo.R`, `normal.X`, `depth.Z`, …). The header carries:
//! - `chromaticities`: the primaries and white point of linear Rec.709 / sRGB (red 0.64, 0.33;
//!   green 0.30, 0.60; blue 0.15, 0.06; white D65 0.3127, 0.3290), which OpenEXR assumes when the
//!   attribute is missing; written so that no reader has to assume.
//! - With [`ExrMetadata`] ([`write_render`]), what pbrt-v4 writes, under the same names:
//!   `renderTimeSeconds` (float), `samplesPerPixel` (int), `worldToCamera` and `worldToNDC`
//!   (m44f, OpenEXR's standard attributes: [`crate::Camera::world_to_camera`] and
//!   [`crate::Camera::world_to_ndc`], stored transposed as Imath multiplies row vectors); and
//!   `software` (OpenEXR's standard attribute: `irr <version>`), plus irr's own strings:
//!   `irr.scene` (the scene's file name), `irr.integrator` (its name), `irr.settings` (its
//!   settings, every field), `irr.seed` (a decimal string: OpenEXR has no 64-bit integer
//!   attribute).
//!
//! # The preview's tone mapping
//! `srgb8(clamp(L · 2^exposure, 0, 1))`: the radiance `L` of each channel is scaled by
//! `2^exposure` (exposure in stops; 0 shows radiance 1 as white), clipped to [0, 1], and
//! encoded with the sRGB transfer function (IEC 61966-2-1: `12.92·v` below 0.0031308, else
//! `1.055·v^(1/2.4) − 0.055`), then rounded to 8 bits. The PNG carries an sRGB chunk. Non-finite
//! values show as black.
//!
//! # Interruption
//! A temporary file is deleted when its write fails or its handle is dropped, but a signal ends
//! the process without running destructors. Every temporary output is therefore listed in a
//! registry while it exists, and [`remove_partial_outputs_on_signals`] installs a SIGINT/SIGTERM
//! (and Ctrl-C) handler that deletes the listed files before the process exits with status 130.

use crate::aov::AovImages;
use crate::error::{RenderError, one_line};
use crate::image::Image as IrrImage;
use irr_scene::Camera;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The temporary output files that exist now, and whether a signal has asked for the exit.
struct Pending {
    paths: Vec<PathBuf>,
    exiting: bool,
}

static PENDING: Mutex<Pending> = Mutex::new(Pending {
    paths: Vec::new(),
    exiting: false,
});

/// The registry, even if a thread panicked while holding it (its list stays meaningful).
fn pending() -> MutexGuard<'static, Pending> {
    PENDING
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Deletes every temporary output file that a write in progress has created, and makes any
/// later attempt to create one fail. Returns how many files it deleted. For signal handlers:
/// call it, then exit.
pub fn remove_partial_outputs() -> usize {
    let mut p = pending();
    p.exiting = true;
    let paths = std::mem::take(&mut p.paths);
    paths
        .iter()
        .filter(|path| std::fs::remove_file(path).is_ok())
        .count()
}

/// Installs a handler for SIGINT, SIGTERM and SIGHUP (Ctrl-C on Windows) that deletes the
/// temporary files of a write in progress ([`remove_partial_outputs`]) and exits with status
/// 130. For programs (like `cargo xtask render`) that write renders; call it once.
pub fn remove_partial_outputs_on_signals() -> Result<(), String> {
    ctrlc::set_handler(|| {
        remove_partial_outputs();
        // Exit while the registry stays locked, so no new temporary file can appear.
        let _held = pending();
        std::process::exit(130);
    })
    .map_err(|e| format!("cannot install the signal handler: {e}"))
}

/// A temporary output file, listed in the registry for as long as it exists (fields drop in
/// order: the file is deleted, then its entry removed).
struct TempOutput {
    file: tempfile::NamedTempFile,
    _listed: Listed,
}

/// A path's entry in the registry, removed on drop.
struct Listed(PathBuf);

impl Drop for Listed {
    fn drop(&mut self) {
        pending().paths.retain(|q| *q != self.0);
    }
}

impl TempOutput {
    fn as_file(&self) -> &std::fs::File {
        self.file.as_file()
    }

    /// Renames the file over `target`, then leaves the registry (on failure the temporary file
    /// is deleted).
    fn persist(self, target: &Path) -> Result<(), std::io::Error> {
        let TempOutput { file, _listed } = self;
        file.persist(target).map(drop).map_err(|e| e.error)
    }
}

/// Checks the preview's exposure before any rendering: a finite number of stops.
pub fn check_exposure(exposure: f32) -> Result<(), RenderError> {
    if exposure.is_finite() {
        Ok(())
    } else {
        Err(RenderError::Setting {
            option: "--exposure",
            problem: format!("must be a finite number of stops, got {exposure}"),
        })
    }
}

/// The PNG preview's path for an EXR path: the same folder and stem, extension `png`.
pub(crate) fn png_path_for(exr_path: &Path) -> PathBuf {
    exr_path.with_extension("png")
}

/// The folder a path's file lives in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Checks, before any rendering, that the output can be written: the path ends in `.exr`, its
/// folder exists (it is created if missing) and accepts new files, and neither the EXR nor its
/// PNG preview is a folder. Leaves nothing behind.
pub fn check_output(exr_path: &Path) -> Result<(), RenderError> {
    let is_exr = exr_path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !is_exr {
        return Err(RenderError::write(
            exr_path,
            "the output must be an .exr file (the PNG preview is written beside it)",
        ));
    }
    let folder = folder_of(exr_path);
    std::fs::create_dir_all(folder).map_err(|e| {
        RenderError::write(
            exr_path,
            format!("cannot create folder {}: {e}", folder.display()),
        )
    })?;
    for target in [exr_path.to_path_buf(), png_path_for(exr_path)] {
        if target.is_dir() {
            return Err(RenderError::write(
                exr_path,
                format!("{} is a folder", target.display()),
            ));
        }
    }
    // A temporary file in the folder proves that it accepts new files; it is deleted on drop.
    temp_in(folder, exr_path).map(drop)
}

/// Checks, before any rendering, that a file can be written at `path` (a cache file, a debug
/// view): its folder exists (it is created if missing) and accepts new files, and `path` is not
/// a folder. Leaves nothing behind.
pub fn check_output_file(path: &Path) -> Result<(), RenderError> {
    let folder = folder_of(path);
    std::fs::create_dir_all(folder).map_err(|e| {
        RenderError::write(
            path,
            format!("cannot create folder {}: {e}", folder.display()),
        )
    })?;
    if path.is_dir() {
        return Err(RenderError::write(path, "it is a folder"));
    }
    temp_in(folder, path).map(drop)
}

/// Writes `bytes` to `path` as [`write_exr_and_png`] writes its files: to a temporary file in
/// the same folder, synced, then renamed over `path`, so a failed or interrupted write leaves
/// any earlier file as it was.
pub(crate) fn write_file_atomically(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    let temp = temp_in(folder_of(path), path)?;
    let mut file = temp.as_file();
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(|e| RenderError::write(path, one_line(e)))?;
    temp.persist(path)
        .map_err(|e| RenderError::write(path, one_line(e)))
}

/// Creates a temporary file for `for_path` in `folder`, listed in the registry (created and
/// listed under its lock, so a signal handler sees every file that exists).
fn temp_in(folder: &Path, for_path: &Path) -> Result<TempOutput, RenderError> {
    let mut p = pending();
    if p.exiting {
        return Err(RenderError::write(for_path, "the program is exiting"));
    }
    let file = new_temp(folder, for_path)?;
    p.paths.push(file.path().to_path_buf());
    let listed = Listed(file.path().to_path_buf());
    Ok(TempOutput {
        file,
        _listed: listed,
    })
}

fn new_temp(folder: &Path, for_path: &Path) -> Result<tempfile::NamedTempFile, RenderError> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".irr-").suffix(".tmp");
    // Temporary files are private (0600) by default; the output is an ordinary file, so ask
    // for 0666 and let the umask narrow it, as `std::fs::write` does.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(folder).map_err(|e| {
        RenderError::write(
            for_path,
            format!("folder {} does not accept new files: {e}", folder.display()),
        )
    })
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// One channel of the preview: see the module docs.
pub fn tone_map(radiance: f32, exposure: f32) -> u8 {
    let v = radiance * exposure.exp2();
    if !v.is_finite() || v <= 0.0 {
        return if v == f32::INFINITY { 255 } else { 0 };
    }
    (srgb_encode(v.min(1.0)) * 255.0).round() as u8
}

/// What a render's OpenEXR header records about how it was made (see the module docs for the
/// attribute each field becomes).
#[derive(Clone, Debug, PartialEq)]
pub struct ExrMetadata {
    /// The program and its version, e.g. `irr 0.1.0` (attribute `software`).
    pub software: String,
    /// The scene's file name (attribute `irr.scene`).
    pub scene: String,
    /// The integrator's name, e.g. `ic` (attribute `irr.integrator`).
    pub integrator: String,
    /// The integrator's settings, every field (attribute `irr.settings`).
    pub settings: String,
    /// Samples per pixel (attribute `samplesPerPixel`; a double beyond `i32::MAX`).
    pub spp: u32,
    /// The seed of every random number (attribute `irr.seed`).
    pub seed: u64,
    /// Wall-clock seconds the render took (attribute `renderTimeSeconds`).
    pub render_seconds: f64,
    /// The camera rendered through (attributes `worldToCamera` and `worldToNDC`).
    pub camera: Camera,
}

/// An OpenEXR text from a Rust string: its UTF-8 bytes (OpenEXR strings are byte strings, read
/// as UTF-8 by current readers), never a panic on characters beyond Latin-1.
fn exr_text(text: &str) -> exr::meta::attribute::Text {
    exr::meta::attribute::Text::from_slice_unchecked(text.as_bytes())
}

/// Linear Rec.709 / sRGB primaries with the D65 white point (ITU-R BT.709-6, item 1.3–1.4).
fn rec709_chromaticities() -> exr::meta::attribute::Chromaticities {
    use exr::math::Vec2;
    exr::meta::attribute::Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    }
}

/// The header attributes of `metadata` for an image of `width` × `height`.
fn metadata_attributes(
    metadata: &ExrMetadata,
    width: u32,
    height: u32,
    layer: &mut exr::meta::header::LayerAttributes,
) {
    use exr::meta::attribute::AttributeValue;
    let to_cols = |m: glam::DMat4| m.to_cols_array().map(|v| v as f32);
    // Imath multiplies row vectors (p' = p·M) and stores M row by row: the transpose of irr's
    // column-vector matrix, which is that matrix's column-major array.
    layer.world_to_camera = Some(to_cols(metadata.camera.world_to_camera()));
    layer.world_to_normalized_device = Some(to_cols(metadata.camera.world_to_ndc(width, height)));
    layer.software_name = Some(exr_text(&metadata.software));
    let spp = i32::try_from(metadata.spp).map_or_else(
        |_| AttributeValue::F64(f64::from(metadata.spp)),
        AttributeValue::I32,
    );
    let attributes = [
        (
            "renderTimeSeconds",
            AttributeValue::F32(metadata.render_seconds as f32),
        ),
        ("samplesPerPixel", spp),
        ("irr.scene", AttributeValue::Text(exr_text(&metadata.scene))),
        (
            "irr.integrator",
            AttributeValue::Text(exr_text(&metadata.integrator)),
        ),
        (
            "irr.settings",
            AttributeValue::Text(exr_text(&metadata.settings)),
        ),
        (
            "irr.seed",
            AttributeValue::Text(exr_text(&metadata.seed.to_string())),
        ),
    ];
    for (name, value) in attributes {
        layer.other.insert(exr_text(name), value);
    }
}

fn encode_exr(
    image: &IrrImage,
    aovs: &AovImages,
    metadata: Option<&ExrMetadata>,
    file: &std::fs::File,
) -> Result<(), String> {
    use exr::prelude::*;
    let (w, h) = (image.width() as usize, image.height() as usize);
    // One channel of an image: its values row by row, row 0 (the top) first, which is
    // OpenEXR's increasing-y order.
    let channel = |name: &str, source: &IrrImage, c: usize| {
        let values: Vec<f32> = source.pixels().iter().map(|p| p[c]).collect();
        AnyChannel::new(exr_text(name), FlatSamples::F32(values))
    };
    let mut channels: Vec<AnyChannel<FlatSamples>> = ["R", "G", "B"]
        .into_iter()
        .enumerate()
        .map(|(c, name)| channel(name, image, c))
        .collect();
    for (aov, layer) in aovs.iter() {
        if (layer.width(), layer.height()) != (image.width(), image.height()) {
            return Err(format!(
                "the {aov} image is {}×{}, the colour {}×{}",
                layer.width(),
                layer.height(),
                image.width(),
                image.height()
            ));
        }
        for (c, name) in aov.channels().iter().enumerate() {
            channels.push(channel(name, layer, c));
        }
    }
    // No layer name: a one-part file needs none, and Blender would take it as a prefix of every
    // channel's name.
    let mut attributes = LayerAttributes::default();
    if let Some(m) = metadata {
        metadata_attributes(m, image.width(), image.height(), &mut attributes);
    }
    let mut layer = Layer::new(
        (w, h),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    // Row 0 of `image` is the top; OpenEXR's increasing-Y line order stores it first.
    layer.encoding.line_order = LineOrder::Increasing;
    let mut exr_image = Image::from_layer(layer);
    exr_image.attributes.chromaticities = Some(rec709_chromaticities());
    let mut out = BufWriter::new(file);
    exr_image.write().to_buffered(&mut out).map_err(one_line)?;
    out.flush().map_err(one_line)
}

fn encode_png(image: &IrrImage, exposure: f32, file: &std::fs::File) -> Result<(), String> {
    let data: Vec<u8> = image
        .pixels()
        .iter()
        .flat_map(|p| p.to_array().map(|c| tone_map(c, exposure)))
        .collect();
    let mut out = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut out, image.width(), image.height());
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(one_line)?;
    writer.write_image_data(&data).map_err(one_line)?;
    writer.finish().map_err(one_line)?;
    out.flush().map_err(one_line)
}

/// Writes `image` to `exr_path` (OpenEXR, f32 RGB, lossless ZIP compression, with the
/// `chromaticities` attribute) and its preview beside it (same stem, extension `png`), tone
/// mapped with `exposure` stops (see the module docs). Returns the two paths written.
///
/// Both files are first written to temporary files in the destination folder, flushed and
/// synced, and only then renamed over the destination, the PNG first and the EXR last: if
/// anything fails, the temporary files are deleted and any earlier output stays as it was.
pub fn write_exr_and_png(
    image: &IrrImage,
    exr_path: &Path,
    exposure: f32,
) -> Result<(PathBuf, PathBuf), RenderError> {
    write_files(image, &AovImages::new(), None, exr_path, exposure)
}

/// [`write_exr_and_png`] for a whole render: the colour, its AOVs as further channels of the
/// same part, and `metadata` in the header (see the module docs). The PNG preview shows the
/// colour only. Written atomically, like [`write_exr_and_png`].
pub fn write_render(
    image: &IrrImage,
    aovs: &AovImages,
    metadata: &ExrMetadata,
    exr_path: &Path,
    exposure: f32,
) -> Result<(PathBuf, PathBuf), RenderError> {
    write_files(image, aovs, Some(metadata), exr_path, exposure)
}

fn write_files(
    image: &IrrImage,
    aovs: &AovImages,
    metadata: Option<&ExrMetadata>,
    exr_path: &Path,
    exposure: f32,
) -> Result<(PathBuf, PathBuf), RenderError> {
    check_output(exr_path)?;
    if image.width() == 0 || image.height() == 0 {
        return Err(RenderError::write(exr_path, "the image is empty"));
    }
    check_exposure(exposure)?;
    let png_path = png_path_for(exr_path);
    let folder = folder_of(exr_path);
    let exr_tmp = temp_in(folder, exr_path)?;
    encode_exr(image, aovs, metadata, exr_tmp.as_file())
        .and_then(|()| exr_tmp.as_file().sync_all().map_err(one_line))
        .map_err(|e| RenderError::write(exr_path, e))?;
    let png_tmp = temp_in(folder, &png_path)?;
    encode_png(image, exposure, png_tmp.as_file())
        .and_then(|()| png_tmp.as_file().sync_all().map_err(one_line))
        .map_err(|e| RenderError::write(&png_path, e))?;
    png_tmp
        .persist(&png_path)
        .map_err(|e| RenderError::write(&png_path, e))?;
    exr_tmp
        .persist(exr_path)
        .map_err(|e| RenderError::write(exr_path, e))?;
    Ok((exr_path.to_path_buf(), png_path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use glam::Vec3;

    fn temp_dir() -> tempfile::TempDir {
        tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
    }

    fn sample_image() -> Image {
        let mut image = Image::new(5, 3);
        for y in 0..3 {
            for x in 0..5 {
                image.set(
                    x,
                    y,
                    Vec3::new(x as f32, y as f32, 1e-3 * (x + 10 * y) as f32),
                );
            }
        }
        image.set(4, 2, Vec3::new(1e30, 0.0, f32::MIN_POSITIVE));
        image
    }

    #[test]
    fn exr_round_trips_bit_for_bit_with_row_0_on_top() {
        let dir = temp_dir();
        let path = dir.path().join("out.exr");
        let image = sample_image();
        let (exr, png) = write_exr_and_png(&image, &path, 0.0).unwrap_or_else(|e| panic!("{e}"));
        assert!(png.exists());
        let back = Image::read_exr(&exr).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back, image);
        assert_eq!(back.get(1, 0), Vec3::new(1.0, 0.0, 1e-3));
        // Nothing else is left in the folder: no temporary files.
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap_or_else(|e| panic!("{e}"))
            .map(|e| e.map(|e| e.file_name()).unwrap_or_default())
            .collect();
        names.sort();
        assert_eq!(names, ["out.exr", "out.png"]);
        // Ordinary permissions, as a file written with std::fs::write in the same folder gets.
        let plain = dir.path().join("plain");
        std::fs::write(&plain, b"x").unwrap_or_else(|e| panic!("{e}"));
        let mode = |p: &Path| std::fs::metadata(p).map(|m| m.permissions()).ok();
        assert_eq!(mode(&exr), mode(&plain));
        assert_eq!(mode(&png), mode(&plain));
    }

    /// A render's EXR: one part with the colour as R, G, B and each AOV's channels, every
    /// value back to the last bit; the chromaticities; the metadata under pbrt-v4's and
    /// OpenEXR's names; no layer name.
    #[test]
    fn render_exr_carries_aovs_chromaticities_and_metadata() {
        use crate::aov::Aov;
        use exr::meta::attribute::{AttributeValue, Text};
        use exr::prelude::{ReadChannels, ReadLayers};
        let dir = temp_dir();
        let path = dir.path().join("r.exr");
        let image = sample_image();
        let mut aovs = AovImages::new();
        let mut albedo = Image::new(5, 3);
        albedo.set(2, 1, Vec3::new(0.25, 0.5, 0.75));
        let mut depth = Image::new(5, 3);
        depth.set(0, 2, Vec3::splat(7.5));
        depth.set(1, 2, Vec3::INFINITY);
        aovs.insert(Aov::Depth, depth.clone());
        aovs.insert(Aov::Albedo, albedo.clone());
        let camera = Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y, 0.7)
            .unwrap_or_else(|| panic!("degenerate"));
        let metadata = ExrMetadata {
            software: "irr 9.9.9".into(),
            scene: "scène.gltf".into(),
            integrator: "path".into(),
            settings: "PathSettings { max_depth: 3, rr_start: 3 }".into(),
            spp: 16,
            seed: u64::MAX,
            render_seconds: 1.5,
            camera,
        };
        write_render(&image, &aovs, &metadata, &path, 0.0).unwrap_or_else(|e| panic!("{e}"));
        // The colour reads back as before.
        assert_eq!(
            Image::read_exr(&path).unwrap_or_else(|e| panic!("{e}")),
            image
        );
        let read = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_file(&path)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(read.layer_data.len(), 1);
        let layer = &read.layer_data[0];
        assert_eq!(layer.attributes.layer_name, None);
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(
            names,
            ["B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "depth.Z"]
        );
        let channel = |name: &str| -> Vec<f32> {
            layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name == Text::from_slice_unchecked(name.as_bytes()))
                .map(|c| c.sample_data.values_as_f32().collect())
                .unwrap_or_else(|| panic!("no channel {name}"))
        };
        let column =
            |img: &Image, c: usize| -> Vec<f32> { img.pixels().iter().map(|p| p[c]).collect() };
        assert_eq!(channel("R"), column(&image, 0));
        assert_eq!(channel("albedo.G"), column(&albedo, 1));
        assert_eq!(channel("depth.Z"), column(&depth, 0));
        assert_eq!(
            read.attributes.chromaticities,
            Some(rec709_chromaticities())
        );
        let a = &layer.attributes;
        assert_eq!(a.software_name, Some(exr_text("irr 9.9.9")));
        let other = |name: &str| a.other.get(&exr_text(name)).cloned();
        assert_eq!(other("samplesPerPixel"), Some(AttributeValue::I32(16)));
        assert_eq!(other("renderTimeSeconds"), Some(AttributeValue::F32(1.5)));
        assert_eq!(
            other("irr.seed"),
            Some(AttributeValue::Text(exr_text("18446744073709551615")))
        );
        assert_eq!(
            other("irr.integrator"),
            Some(AttributeValue::Text(exr_text("path")))
        );
        // A name beyond Latin-1 is stored as its UTF-8 bytes.
        assert_eq!(
            other("irr.scene"),
            Some(AttributeValue::Text(exr_text("scène.gltf")))
        );
        // The matrices, as Imath stores them (row-vector convention): a point times
        // worldToCamera is the camera-space point; the camera's position goes to the origin.
        let m = a
            .world_to_camera
            .unwrap_or_else(|| panic!("no worldToCamera"));
        let p = [1.0f32, 2.0, 3.0, 1.0];
        let row_times = |m: &[f32; 16], v: [f32; 4]| -> [f32; 4] {
            std::array::from_fn(|c| (0..4).map(|r| v[r] * m[4 * r + c]).sum())
        };
        let q = row_times(&m, p);
        assert!(
            q[..3].iter().all(|v| v.abs() < 1e-6) && q[3] == 1.0,
            "{q:?}"
        );
        // The point the camera looks at projects to the image's centre, NDC (0.5, 0.5).
        let ndc = a
            .world_to_normalized_device
            .unwrap_or_else(|| panic!("no worldToNDC"));
        let q = row_times(&ndc, [0.0, 0.0, 0.0, 1.0]);
        assert!((q[0] / q[3] - 0.5).abs() < 1e-6 && (q[1] / q[3] - 0.5).abs() < 1e-6);
        // The plain writer has the chromaticities too, and no metadata.
        let plain = dir.path().join("plain.exr");
        write_exr_and_png(&image, &plain, 0.0).unwrap_or_else(|e| panic!("{e}"));
        let meta =
            exr::meta::MetaData::read_from_file(&plain, false).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            meta.headers[0].shared_attributes.chromaticities,
            Some(rec709_chromaticities())
        );
        assert!(meta.headers[0].own_attributes.other.is_empty());
        // An AOV of the wrong size is refused, and the earlier file stays as it was.
        let before = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut bad = AovImages::new();
        bad.insert(Aov::Normal, Image::new(2, 2));
        let e = write_render(&image, &bad, &metadata, &path, 0.0)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("the normal image is 2×2, the colour 5×3"), "{e}");
        assert_eq!(
            std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")),
            before
        );
    }

    #[test]
    fn png_is_a_tone_mapped_srgb_preview() {
        let dir = temp_dir();
        let path = dir.path().join("p.exr");
        let mut image = Image::new(3, 1);
        image.set(0, 0, Vec3::new(0.0, 1.0, 2.0));
        image.set(1, 0, Vec3::new(0.5, 0.0031308, f32::NAN));
        image.set(2, 0, Vec3::splat(0.25));
        write_exr_and_png(&image, &path, 1.0).unwrap_or_else(|e| panic!("{e}"));
        let file = std::fs::File::open(png_path_for(&path)).unwrap_or_else(|e| panic!("{e}"));
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .unwrap_or_else(|e| panic!("{e}"));
        let mut buf = vec![0; reader.output_buffer_size().unwrap_or(0)];
        let info = reader
            .next_frame(&mut buf)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((info.width, info.height), (3, 1));
        // Exposure +1 doubles: 0.5 → 1.0 → 255; 0.25 → 0.5 → sRGB 0.7354 → 188.
        assert_eq!(&buf[..9], &[0, 255, 255, 255, 18, 0, 188, 188, 188]);
    }

    #[test]
    fn tone_map_values() {
        assert_eq!(tone_map(0.0, 0.0), 0);
        assert_eq!(tone_map(1.0, 0.0), 255);
        assert_eq!(tone_map(-3.0, 0.0), 0);
        assert_eq!(tone_map(f32::NAN, 0.0), 0);
        assert_eq!(tone_map(f32::INFINITY, 0.0), 255);
        // 0.5 in linear light is 0.7354 in sRGB (IEC 61966-2-1): 187.5 → 188.
        assert_eq!(tone_map(0.5, 0.0), 188);
        assert_eq!(tone_map(0.25, 1.0), 188);
    }

    #[test]
    fn failed_write_keeps_the_earlier_output() {
        let dir = temp_dir();
        let path = dir.path().join("keep.exr");
        let first = sample_image();
        write_exr_and_png(&first, &path, 0.0).unwrap_or_else(|e| panic!("{e}"));
        let before = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        // An empty image cannot be written: the call fails and the earlier file is untouched.
        let err = write_exr_and_png(&Image::new(0, 0), &path, 0.0);
        assert!(err.is_err());
        assert_eq!(
            std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")),
            before
        );
    }

    #[test]
    fn bad_output_paths_are_refused_up_front() {
        let dir = temp_dir();
        let not_exr = dir.path().join("out.png");
        let e = check_output(&not_exr)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("out.png") && e.contains(".exr"), "{e}");
        // A folder under a regular file cannot be created.
        let file = dir.path().join("plain");
        std::fs::write(&file, b"x").unwrap_or_else(|e| panic!("{e}"));
        let under_file = file.join("out.exr");
        let e = check_output(&under_file)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("plain") && e.contains("cannot create folder"),
            "{e}"
        );
        // The PNG's place is taken by a folder.
        std::fs::create_dir(dir.path().join("taken.png")).unwrap_or_else(|e| panic!("{e}"));
        let e = check_output(&dir.path().join("taken.exr"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("taken.png is a folder"), "{e}");
    }
}
