//! Walkthroughs: one cache shared by the frames of a camera path (irr-render's
//! `build_shared_cache`), read by every frame without adding records.

use irr_integrator::Integrator;
use irr_render::{
    Camera, IcSettings, Image, IrradianceCacheIntegrator, RenderSettings, build_shared_cache,
    load_scene, render,
};
use std::path::Path;

/// The Cornell box's camera moved sideways by `dx` metres.
fn shifted(camera: &Camera, dx: f32) -> Camera {
    Camera {
        position: camera.position + camera.right * dx,
        ..*camera
    }
}

fn bits(image: &Image) -> Vec<u32> {
    image
        .pixels()
        .iter()
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Builds the shared cache of `views` on `threads` threads, then renders the frames in
/// `order`; the frames' bits by view, and the record count before and after the frames.
fn walk(views: &[Camera], threads: usize, order: &[usize]) -> (Vec<Vec<u32>>, usize, usize) {
    let loaded =
        load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/cornell-box.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 2,
        seed: 5,
        threads,
    };
    let mut ic = IrradianceCacheIntegrator::new(IcSettings {
        strata_m: 6,
        strata_n: 24,
        light_cache_paths: 20_000,
        ..IcSettings::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    ic.preprocess(&loaded.scene);
    build_shared_cache(&loaded.scene, views, &mut ic, &settings, false, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let before = ic.cache(0).map_or(0, |c| c.len());
    let mut frames = vec![Vec::new(); views.len()];
    for &i in order {
        let image = render(&loaded.scene, &views[i], &ic, &settings, false)
            .unwrap_or_else(|e| panic!("{e}"))
            .image;
        frames[i] = bits(&image);
    }
    let after = ic.cache(0).map_or(0, |c| c.len());
    (frames, before, after)
}

/// A shared cache serves every frame read-only (the record count does not change as frames
/// render), so a frame's image does not depend on which frames rendered before it nor on the
/// thread count: the same bits in any order and on 1 or 3 threads. Each key frame's view adds
/// records where the earlier views did not cover its points.
#[test]
fn frames_read_one_shared_cache_in_any_order() {
    let loaded =
        load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/cornell-box.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
    let rest = loaded.camera_for(24, 24);
    let views = [shifted(&rest, -0.15), rest, shifted(&rest, 0.15)];
    let (forward, before, after) = walk(&views, 1, &[0, 1, 2]);
    assert_eq!(before, after, "a frame added records to the shared cache");
    let (backward, ..) = walk(&views, 3, &[2, 1, 0]);
    assert_eq!(forward, backward, "frames depend on order or threads");
    let (alone, single, _) = walk(&views[..1], 1, &[0]);
    assert!(
        before > single,
        "the other views added no record ({before} vs {single})"
    );
    assert_ne!(
        alone[0], forward[0],
        "a bigger cache left the first frame unchanged"
    );
}
