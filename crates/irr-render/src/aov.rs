//! Arbitrary output variables (AOVs): images a render writes beside the colour, for a
//! compositor (Nuke, Blender, tev) or a denoiser (Intel Open Image Denoise takes colour + albedo
//! + normal).
//!
//! # What each one holds
//! Every AOV is a per-pixel average over the pixel's samples, with the colour's box filter and
//! its raster positions, summed in f64 in sample order (so, like the colour, the same bits for
//! any thread count):
//! - `albedo`: the diffuse reflectance ρ of the surface the camera ray meets first; 0 where it
//!   meets nothing. In [0, 1], linear, as OIDN asks.
//! - `normal`: that surface's unit shading normal in world space, turned towards the camera; 0
//!   where the ray meets nothing. The average of unit normals, not renormalised (OIDN: "the final
//!   accumulated normals do not have to be normalized but must be in the [-1, 1] range").
//! - `depth`: the distance from the centre of projection to the first hit along the camera ray
//!   (not the camera-space z), averaged over the samples that hit something; +∞ where none did
//!   (a mean taken over all samples would be +∞ or, with 0 for a miss, pull silhouettes towards
//!   the camera).
//! - `emitted`, `direct`, `indirect`: the integrator's split of the colour
//!   ([`irr_integrator::Radiance`]): the first surface's own emission, light reflected once
//!   there, light reflected two or more times. Their sum is the colour up to f32 rounding.
//!   Ambient occlusion has no split: it is all `emitted`. A sample whose colour is NaN or
//!   infinite counts as black in all three, as in the colour.
//! - `glossy-indirect`: the part of `indirect` that the first surface reflects through its BSDF
//!   minus the diffuse stand-in ρ_d/π an irradiance cache multiplies its irradiance by (f −
//!   ρ_d/π, the glossy lobes and the diffuse lobe's departure from its stand-in): zero on a
//!   Lambertian surface, and negative where that departure outweighs the lobes. Both
//!   integrators estimate the same quantity (the cache's glossy sample or radiance records, the
//!   path tracer's first BSDF sample through the residual's share of its weight), so it scores
//!   a cache's glossy indirect light apart from its diffuse part (Cycles' "Glossy Indirect").
//! - `noisy`: with `--denoise`, the colour as rendered; `R`, `G`, `B` then hold the denoised
//!   colour (Blender's "Noisy Image" pass beside its denoised "Combined"), so a viewer shows the
//!   denoised image first and keeps the raw one a click away.
//!
//! # Channel names in the OpenEXR file
//! One part (one header), every channel 32-bit float: the colour as `R`, `G`, `B` (what every
//! reader shows first; Blender calls it "Combined"), and each AOV as `<name>.<channel>`, the
//! OpenEXR convention for layers inside one part: `albedo.R/G/B`, `normal.X/Y/Z`, `depth.Z`,
//! `emitted.R/G/B`, `direct.R/G/B`, `indirect.R/G/B`, `glossy-indirect.R/G/B`, `noisy.R/G/B`. tev lists them as
//! layers, Nuke as layers `albedo`, `normal`, … (and `depth.Z` is Nuke's own depth channel),
//! and Blender's Image node as passes of the same names (it splits a channel name at its last
//! two dots into view layer, pass and channel, and reads a three-channel pass with X, Y, Z as a
//! vector). irr denoises with OIDN itself (`--denoise`, [`crate::denoise()`]); for another
//! denoiser, extract the planes, e.g. `oiiotool render.exr --ch albedo.R,albedo.G,albedo.B -o
//! albedo.pfm`.

use crate::image::Image;

/// One auxiliary image a render can write beside the colour (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Aov {
    /// Diffuse reflectance at the first hit.
    Albedo,
    /// World-space shading normal at the first hit, turned towards the camera.
    Normal,
    /// Distance from the camera to the first hit.
    Depth,
    /// The first surface's own emission (paths `L E`).
    Emitted,
    /// Light reflected once, at the first surface (paths `L D E`).
    Direct,
    /// Light reflected two or more times (paths `L D D+ E`).
    Indirect,
    /// Of `Indirect`, what the first surface reflects through its BSDF minus the diffuse stand-in
    /// (f − ρ_d/π): the glossy lobes' indirect light.
    GlossyIndirect,
    /// The colour as rendered, before denoising: written beside a denoised colour (`--denoise`),
    /// never requested from a render, so not in [`Aov::ALL`].
    Noisy,
}

impl Aov {
    /// Every AOV a render can make (what `--aov` accepts), in the order they are listed and
    /// written.
    pub const ALL: [Aov; 7] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Emitted,
        Aov::Direct,
        Aov::Indirect,
        Aov::GlossyIndirect,
    ];

    /// The name on the command line (`--aov albedo,normal`) and the layer's name in the file.
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Emitted => "emitted",
            Aov::Direct => "direct",
            Aov::Indirect => "indirect",
            Aov::GlossyIndirect => "glossy-indirect",
            Aov::Noisy => "noisy",
        }
    }

    /// The AOV called `name` (exactly as [`Aov::name`] spells it, surrounding spaces ignored).
    /// The error names the text and lists the valid names.
    pub fn from_name(name: &str) -> Result<Self, String> {
        let name = name.trim();
        Self::ALL
            .into_iter()
            .find(|a| a.name() == name)
            .ok_or_else(|| {
                format!(
                    "unknown AOV '{}'; the valid ones are {}",
                    crate::error::one_line(name),
                    Self::ALL.map(Aov::name).join(", ")
                )
            })
    }

    /// The channel names of its layer in the OpenEXR file, e.g. `albedo.R`, `albedo.G`,
    /// `albedo.B`. A one-channel AOV (depth) writes only the first value of each pixel.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Aov::Albedo => &["albedo.R", "albedo.G", "albedo.B"],
            Aov::Normal => &["normal.X", "normal.Y", "normal.Z"],
            Aov::Depth => &["depth.Z"],
            Aov::Emitted => &["emitted.R", "emitted.G", "emitted.B"],
            Aov::Direct => &["direct.R", "direct.G", "direct.B"],
            Aov::Indirect => &["indirect.R", "indirect.G", "indirect.B"],
            Aov::GlossyIndirect => &[
                "glossy-indirect.R",
                "glossy-indirect.G",
                "glossy-indirect.B",
            ],
            Aov::Noisy => &["noisy.R", "noisy.G", "noisy.B"],
        }
    }

    /// Whether it needs the camera ray's first hit (albedo, normal, depth), traced once more
    /// beside the integrator.
    pub fn needs_first_hit(self) -> bool {
        matches!(self, Aov::Albedo | Aov::Normal | Aov::Depth)
    }

    /// Whether it needs the integrator's split of the colour (emitted, direct, indirect and its
    /// glossy part).
    pub fn needs_split(self) -> bool {
        matches!(
            self,
            Aov::Emitted | Aov::Direct | Aov::Indirect | Aov::GlossyIndirect
        )
    }
}

impl std::fmt::Display for Aov {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The AOVs of a render, each an [`Image`] of the colour's size, in [`Aov::ALL`]'s order.
/// Depth holds its distance in all three channels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AovImages {
    layers: Vec<(Aov, Image)>,
}

impl AovImages {
    /// No AOVs.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) one; the list stays in [`Aov::ALL`]'s order.
    pub fn insert(&mut self, aov: Aov, image: Image) {
        self.layers.retain(|(a, _)| *a != aov);
        self.layers.push((aov, image));
        self.layers.sort_by_key(|(a, _)| *a);
    }

    /// The image of `aov`, if the render made one.
    pub fn get(&self, aov: Aov) -> Option<&Image> {
        self.layers.iter().find(|(a, _)| *a == aov).map(|(_, i)| i)
    }

    /// Every AOV and its image, in [`Aov::ALL`]'s order.
    pub fn iter(&self) -> impl Iterator<Item = (Aov, &Image)> {
        self.layers.iter().map(|(a, i)| (*a, i))
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.layers.is_empty()
    }
}

/// The AOVs in `aovs` without repeats, in [`Aov::ALL`]'s order.
pub fn normalise_aovs(aovs: &[Aov]) -> Vec<Aov> {
    Aov::ALL.into_iter().filter(|a| aovs.contains(a)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_list_the_valid_ones() {
        for a in Aov::ALL {
            assert_eq!(Aov::from_name(a.name()), Ok(a));
            assert!(a.channels()[0].starts_with(&format!("{}.", a.name())));
        }
        assert_eq!(Aov::from_name(" depth "), Ok(Aov::Depth));
        let e = Aov::from_name("foo").err().unwrap_or_default();
        assert_eq!(
            e,
            "unknown AOV 'foo'; the valid ones are albedo, normal, depth, emitted, direct, \
             indirect, glossy-indirect"
        );
        // A name from a user is escaped in the message.
        let e = Aov::from_name("a\nb").err().unwrap_or_default();
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn sets_are_ordered_and_deduplicated() {
        assert_eq!(
            normalise_aovs(&[Aov::Depth, Aov::Albedo, Aov::Depth]),
            [Aov::Albedo, Aov::Depth]
        );
        let mut images = AovImages::new();
        images.insert(Aov::Normal, Image::new(1, 1));
        images.insert(Aov::Albedo, Image::new(1, 1));
        let order: Vec<Aov> = images.iter().map(|(a, _)| a).collect();
        assert_eq!(order, [Aov::Albedo, Aov::Normal]);
        assert!(images.get(Aov::Depth).is_none());
    }
}
