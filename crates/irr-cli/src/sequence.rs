//! A walkthrough's shared cache (`--frames A..B --shared-cache`): built from the key frames'
//! views in shards, kept in a cache file (`--cache FILE`), and read by every frame; and
//! `irr cache merge`, which joins shard files that other processes or machines built
//! (`--shard I`).
//!
//! One process and a farm give the same bits: the process builds shard 0, 1, … in turn, each
//! into an empty cache, and joins them with irr-render's `merge_shards`, exactly as `irr cache
//! merge` joins the shard files; every frame then reads the joined records into a fresh
//! integrator and rebuilds the light cache from the first key frame's view, as a process that
//! reads the file does.

use crate::render::{MAX_CACHE_FILE_BYTES, RenderArgs, view_settings};
use irr_render::{
    CacheContents, CacheOrigin, Camera, IcSettings, Integrator, IrradianceCacheIntegrator,
    KeyFrames, LoadedScene, RenderSettings, build_cache_shard, build_light_cache,
    check_fingerprint, fingerprint, merge_shards,
};
use std::path::{Path, PathBuf};

/// What a sequence's records depend on, hashed: every byte the scene was read from (`digest`),
/// the image size, the cache's settings (their Debug text: every field, floats to the last
/// bit), the background, the seed (and the samples per pixel with `fill_samples`, whose
/// candidates are the camera samples), the key frames (the camera and the times, to the bit)
/// and the shard count. Not which frames are rendered, nor the thread count.
pub fn sequence_fingerprint(
    digest: u64,
    settings: &RenderSettings,
    ic: &IcSettings,
    background: [f32; 3],
    keys: &KeyFrames,
    shards: u32,
) -> u64 {
    let spp = if ic.fill_samples { settings.spp } else { 0 };
    let rest = format!(
        "sequence {}x{} {ic:?} background {background:?} seed {} spp {spp} shards {shards} camera {:?}",
        settings.width, settings.height, settings.seed, keys.camera
    );
    let times: Vec<u8> = keys
        .times
        .iter()
        .flat_map(|t| t.to_bits().to_le_bytes())
        .collect();
    fingerprint(&[&digest.to_le_bytes(), rest.as_bytes(), &times])
}

/// The key frames of `--frames a..b`: every `--cache-every`-th frame from `a`, and the last.
pub fn key_frames(args: &RenderArgs, (a, b): (u32, u32)) -> Result<(Vec<u32>, KeyFrames), String> {
    let mut frames: Vec<u32> = (a..b).step_by(args.cache_every as usize).collect();
    if frames.last() != Some(&(b - 1)) {
        frames.push(b - 1);
    }
    let camera = args
        .camera
        .map(|c| u32::try_from(c).map_err(|_| format!("--camera: {c} is out of range")))
        .transpose()?;
    let times = frames.iter().map(|&f| f64::from(f) / args.fps).collect();
    Ok((frames, KeyFrames { camera, times }))
}

/// The views of `keys`: the scene's camera at each time (its framing of the bounds when the file
/// has none), and the render settings at the image size they give.
fn key_views(
    args: &RenderArgs,
    loaded: &LoadedScene,
    keys: &KeyFrames,
    spp: i64,
) -> Result<(Vec<Camera>, RenderSettings), String> {
    let camera = keys.camera.map(|c| c as usize);
    let mut views = Vec::with_capacity(keys.times.len());
    for &t in &keys.times {
        views.push(
            loaded
                .choose_camera_at(camera, Some(t))
                .map_err(|e| e.to_string())?,
        );
    }
    let settings = view_settings(args, views.first().and_then(Option::as_ref), spp)?;
    let framing = || {
        Camera::framing(
            loaded.bounds.0,
            loaded.bounds.1,
            settings.width as f32 / settings.height as f32,
        )
    };
    Ok((
        views
            .into_iter()
            .map(|c| c.unwrap_or_else(framing))
            .collect(),
        settings,
    ))
}

/// Checks `--shards` against the key frames (its range and `--shard`'s are `run`'s checks).
fn check_shards(args: &RenderArgs, keys: usize) -> Result<(), String> {
    if args.shards as usize > keys {
        return Err(format!(
            "--shards: {} shards but the frames have only {keys} key frames (--cache-every {}); use fewer shards or a smaller --cache-every",
            args.shards, args.cache_every
        ));
    }
    Ok(())
}

/// What `--shared-cache` leaves for the frames: the integrator that reads the sequence's cache,
/// or nothing to render (`--shard I` built and wrote one shard).
pub enum Shared {
    /// Every frame reads this integrator's cache.
    Frames(Box<IrradianceCacheIntegrator>),
    /// A shard was written (or was already there); no frame is rendered.
    ShardOnly,
}

/// The cache of `--shared-cache` for frames `a..b`: read from `--cache FILE` if it exists (a
/// joined sequence's cache made for this scene and these settings), otherwise built (all
/// shards, or with `--shard I` that shard alone, written to FILE) and, with `--cache`, written.
pub fn shared_cache(
    args: &RenderArgs,
    loaded: &LoadedScene,
    frames: (u32, u32),
    spp: i64,
    s: IcSettings,
) -> Result<Shared, String> {
    // One cache serves every frame only if nothing but the camera moves; irr renders meshes
    // and lights in their rest pose, so a moving one would be wrong in every frame.
    if loaded.animated_content > 0 {
        return Err(format!(
            "--shared-cache: {}: {} animation channel(s) move meshes or lights (irr renders them in their rest pose); a shared cache needs a scene where only cameras move",
            loaded.path.display(),
            loaded.animated_content
        ));
    }
    let (numbers, keys) = key_frames(args, frames)?;
    let path = args.ic.cache.as_deref();
    // A sequence's cache file serves any of its frames, whatever --frames and --shards say now.
    if let Some(path) = path
        && std::fs::symlink_metadata(path).is_ok()
    {
        let contents =
            CacheContents::read(path, MAX_CACHE_FILE_BYTES).map_err(|e| e.to_string())?;
        return read_back(args, loaded, path, contents, spp, s, &keys);
    }
    check_shards(args, numbers.len())?;
    let (views, settings) = key_views(args, loaded, &keys, spp)?;
    let fp = sequence_fingerprint(
        loaded.digest,
        &settings,
        &s,
        args.background,
        &keys,
        args.shards,
    );
    let listed: Vec<String> = numbers.iter().map(u32::to_string).collect();
    let which: Vec<u32> = match args.shard {
        Some(i) => vec![i],
        None => (0..args.shards).collect(),
    };
    let mut built = Vec::with_capacity(which.len());
    for &index in &which {
        let range = keys.shard(index, args.shards);
        let mut ic = IrradianceCacheIntegrator::new(s).map_err(|e| e.to_string())?;
        ic.preprocess(&loaded.scene);
        let stats = build_cache_shard(
            &loaded.scene,
            &views,
            range.clone(),
            &mut ic,
            &settings,
            s.fill_samples,
            true,
        )
        .map_err(|e| e.to_string())?;
        let origin = CacheOrigin::Shard {
            index,
            shards: args.shards,
            keys: keys.clone(),
        };
        if args.shards == 1 {
            eprintln!(
                "shared cache from {} key frames ({}): {}",
                listed.len(),
                listed.join(", "),
                stats.summary()
            );
        } else {
            eprintln!(
                "shared cache, shard {index} of {} (key frames {}): {}",
                args.shards,
                listed[range].join(", "),
                stats.summary()
            );
        }
        built.push((
            path.map_or_else(|| PathBuf::from("(memory)"), Path::to_path_buf),
            CacheContents::of(&ic, fp, origin)?,
        ));
    }
    if args.shard.is_some() {
        let (path, shard) = built.pop().ok_or("--shard: no shard was built")?;
        shard
            .write(&path, MAX_CACHE_FILE_BYTES)
            .map_err(|e| e.to_string())?;
        eprintln!(
            "wrote shard {} of {} ({} records) to {}; join the shards with `irr cache merge`",
            args.shard.unwrap_or(0),
            args.shards,
            shard.record_count(),
            path.display()
        );
        return Ok(Shared::ShardOnly);
    }
    let (merged, report) = merge_shards(built).map_err(|e| e.to_string())?;
    if args.shards > 1 {
        eprintln!(
            "shared cache: {} records from {} shards ({} duplicates dropped)",
            merged.record_count(),
            args.shards,
            report.duplicates
        );
    }
    if let Some(path) = path {
        merged
            .write(path, MAX_CACHE_FILE_BYTES)
            .map_err(|e| e.to_string())?;
        eprintln!(
            "wrote the sequence's cache ({} records) to {}",
            merged.record_count(),
            path.display()
        );
    }
    frames_integrator(args, loaded, merged, spp, s).map(|ic| Shared::Frames(Box::new(ic)))
}

/// A cache file found at `--cache` for `--shared-cache`: a joined sequence's cache whose
/// fingerprint matches is read; a shard matching `--shard` is left as it is (nothing to do); the
/// rest is refused with what to do.
fn read_back(
    args: &RenderArgs,
    loaded: &LoadedScene,
    path: &Path,
    contents: CacheContents,
    spp: i64,
    s: IcSettings,
    keys: &KeyFrames,
) -> Result<Shared, String> {
    let bad = |problem: String| format!("{}: {problem}", path.display());
    let (file_keys, shards) = contents.origin.sequence().ok_or_else(|| {
        bad("this file holds one view's cache; --shared-cache needs a sequence's (delete it or choose another file)".into())
    })?;
    // The records were placed and sized along that camera's path, and the frames' light cache
    // is rebuilt from its first key frame: another camera's frames would not find them.
    if file_keys.camera.unwrap_or(0) != keys.camera.unwrap_or(0) {
        let name = |c: Option<u32>| format!("camera {}", c.unwrap_or(0));
        return Err(bad(format!(
            "--camera: this cache was built along {}'s path, not {}'s",
            name(file_keys.camera),
            name(keys.camera)
        )));
    }
    let (_, settings) = key_views(args, loaded, file_keys, spp).map_err(bad)?;
    let expected = sequence_fingerprint(
        loaded.digest,
        &settings,
        &s,
        args.background,
        file_keys,
        shards,
    );
    check_fingerprint(path, contents.fingerprint, expected).map_err(|e| e.to_string())?;
    match (&contents.origin, args.shard) {
        (&CacheOrigin::Shard { index: found, .. }, Some(i))
            if found == i && shards == args.shards && file_keys == keys =>
        {
            eprintln!(
                "{} already holds shard {i} of {shards} of this sequence's cache: nothing to build",
                path.display()
            );
            Ok(Shared::ShardOnly)
        }
        (CacheOrigin::Shard { index, .. }, Some(i)) => Err(bad(format!(
            "this file holds shard {index} of {shards} of a sequence's cache, not shard {i} of {} of these frames; give each shard a file of its own",
            args.shards
        ))),
        (CacheOrigin::Shard { index, .. }, None) => Err(bad(format!(
            "this file holds shard {index} of {shards} of a sequence's cache; join the shards with `irr cache merge` and read the joined file"
        ))),
        (_, Some(_)) => Err(bad(
            "this file already holds a joined sequence's cache; --shard writes a shard to a file of its own".into(),
        )),
        _ => {
            eprintln!(
                "read {} records from {} ({} key frames, {shards} shards): no construction pass",
                contents.record_count(),
                path.display(),
                file_keys.times.len()
            );
            if file_keys != keys || shards != args.shards {
                eprintln!(
                    "note: the file's key frames and shards are used; --frames, --fps, --cache-every and --shards shape a cache only when it is built"
                );
            }
            frames_integrator(args, loaded, contents, spp, s)
                .map(|ic| Shared::Frames(Box::new(ic)))
                .map_err(bad)
        }
    }
}

/// The integrator every frame reads: a fresh one with the sequence's records, and the light
/// cache rebuilt from the first key frame's view (the same bits every shard's construction
/// used).
fn frames_integrator(
    args: &RenderArgs,
    loaded: &LoadedScene,
    contents: CacheContents,
    spp: i64,
    s: IcSettings,
) -> Result<IrradianceCacheIntegrator, String> {
    let keys = contents
        .origin
        .sequence()
        .map(|(k, _)| k.clone())
        .ok_or("a sequence's cache has key frames")?;
    let first = KeyFrames {
        camera: keys.camera,
        times: keys.times.into_iter().take(1).collect(),
    };
    let (views, settings) = key_views(args, loaded, &first, spp)?;
    let levels = contents.file(&s)?;
    let mut ic = IrradianceCacheIntegrator::new(s).map_err(|e| e.to_string())?;
    ic.preprocess(&loaded.scene);
    ic.load_levels(levels).map_err(|e| e.to_string())?;
    if let Some(view) = views.first() {
        build_light_cache(&loaded.scene, view, &mut ic, &settings).map_err(|e| e.to_string())?;
    }
    Ok(ic)
}

/// `irr cache merge SHARD… -o OUT`: joins the shard files of one sequence's cache (any order)
/// into OUT; returns the summary line.
pub fn merge(shards: &[PathBuf], out: &Path) -> Result<String, String> {
    if shards.is_empty() {
        return Err("irr cache merge: name the shard files to join".into());
    }
    irr_render::check_output_file(out).map_err(|e| e.to_string())?;
    let mut read = Vec::with_capacity(shards.len());
    for path in shards {
        let contents =
            CacheContents::read(path, MAX_CACHE_FILE_BYTES).map_err(|e| e.to_string())?;
        read.push((path.clone(), contents));
    }
    let (merged, report) = merge_shards(read).map_err(|e| e.to_string())?;
    merged
        .write(out, MAX_CACHE_FILE_BYTES)
        .map_err(|e| e.to_string())?;
    let per_shard: Vec<String> = report.shard_records.iter().map(usize::to_string).collect();
    Ok(format!(
        "wrote {} records to {} (shards' records {}; {} duplicates dropped)",
        merged.record_count(),
        out.display(),
        per_shard.join(" + "),
        report.duplicates
    ))
}
