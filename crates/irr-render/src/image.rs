//! [`Image`]: a linear-radiance RGB image, row 0 at the top, and reading one back from OpenEXR.

use crate::error::{RenderError, one_line};
use glam::Vec3;
use std::path::Path;

/// A `width` × `height` image of linear RGB values (radiance in W·sr⁻¹·m⁻² per channel for a
/// rendered image), stored row by row with **row 0 at the top**.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// An image from its pixels, row 0 first; `None` if `pixels.len() != width · height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Option<Self> {
        (pixels.len() == width as usize * height as usize).then_some(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// All pixels, row by row, row 0 (the top) first.
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// The pixel in column `x`, row `y` (row 0 is the top). Panics if out of range, like slice
    /// indexing: coordinates come from the program, never from a file.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) out of range"
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets the pixel in column `x`, row `y`. Panics if out of range.
    pub fn set(&mut self, x: u32, y: u32, value: Vec3) {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) out of range"
        );
        self.pixels[y as usize * self.width as usize + x as usize] = value;
    }

    /// The mean of all pixels, summed in f64.
    pub fn mean(&self) -> Vec3 {
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            for (s, c) in sum.iter_mut().zip(p.to_array()) {
                *s += f64::from(c);
            }
        }
        let n = self.pixels.len().max(1) as f64;
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }

    /// Reads the R, G and B channels of the first RGB(A) layer of an OpenEXR file.
    pub fn read_exr(path: &Path) -> Result<Self, RenderError> {
        let fail = |problem: String| RenderError::ReadImage {
            path: path.to_path_buf(),
            problem,
        };
        let read = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |resolution, _| {
                (
                    resolution.width(),
                    vec![Vec3::ZERO; resolution.width() * resolution.height()],
                )
            },
            |(width, pixels): &mut (usize, Vec<Vec3>),
             position,
             (r, g, b, _): (f32, f32, f32, f32)| {
                pixels[position.y() * *width + position.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(|e| fail(one_line(e)))?;
        let size = read.layer_data.size;
        let (width, height) = (
            u32::try_from(size.width()).map_err(|e| fail(e.to_string()))?,
            u32::try_from(size.height()).map_err(|e| fail(e.to_string()))?,
        );
        let (_, pixels) = read.layer_data.channel_data.pixels;
        Self::from_pixels(width, height, pixels)
            .ok_or_else(|| fail("pixel count does not match the data window".to_string()))
    }
}
