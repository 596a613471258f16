//! The progressive image: per-pixel sums of samples, split into disjoint tiles for parallel
//! tracing, and resolved to RGBA8 for display.

use super::tonemap::{Tonemap, linear_to_srgb8};
use glam::Vec3;
use std::ops::Range;

/// A progressively refined image: per pixel, the sum of its samples' linear RGB and their
/// count, so that the mean sharpens as samples are added, frame after frame, until the view
/// changes and [`restart`](Self::restart) clears it.
///
/// Each pixel keeps its own count, and a tracer asked to add a sample to a pixel gives it
/// sample index `count`: a pixel's samples follow its own sequence whatever rows a frame
/// reached, so a frame may stop anywhere (see [`PreviewImage::next_rows`]).
///
/// ```
/// use spatial_accel::preview::{PreviewImage, Tonemap};
/// let mut image = PreviewImage::new(4, 2);
/// let mut rgba = Vec::new();
/// image.resolve_rgba8(Tonemap::Clamp, 1.0, &mut rgba);
/// // Nothing traced yet: transparent black.
/// assert_eq!(rgba, vec![0; 4 * 2 * 4]);
/// assert_eq!(image.next_rows(3), 0..2);
/// assert_eq!(image.next_rows(3), 0..2);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PreviewImage {
    width: u32,
    height: u32,
    sums: Vec<Vec3>,
    counts: Vec<u32>,
    /// The first row of the next [`next_rows`](Self::next_rows) range.
    cursor: u32,
}

/// A band of whole rows of a [`PreviewImage`], borrowed mutably: tiles from one
/// [`PreviewImage::tiles`] call are disjoint, so each can go to its own thread.
#[derive(Debug)]
pub struct ImageTile<'a> {
    rows: Range<u32>,
    width: u32,
    height: u32,
    sums: &'a mut [Vec3],
    counts: &'a mut [u32],
}

impl ImageTile<'_> {
    /// The image rows the tile covers.
    pub fn rows(&self) -> Range<u32> {
        self.rows.clone()
    }

    /// The whole image's width and height (the camera maps pixels through these).
    pub fn image_size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Samples so far of pixel `(x, y)` (`y` an image row inside the tile): the index the
    /// next sample of that pixel takes.
    pub fn sample_count(&self, x: u32, y: u32) -> u32 {
        self.counts[self.offset(x, y)]
    }

    /// Adds one sample's value to pixel `(x, y)`. A non-finite value is added as black, so
    /// that one broken sample cannot poison a pixel for the rest of its accumulation.
    pub fn add_sample(&mut self, x: u32, y: u32, value: Vec3) {
        let i = self.offset(x, y);
        self.sums[i] += if value.is_finite() { value } else { Vec3::ZERO };
        self.counts[i] = self.counts[i].saturating_add(1);
    }

    fn offset(&self, x: u32, y: u32) -> usize {
        (y - self.rows.start) as usize * self.width as usize + x as usize
    }
}

impl PreviewImage {
    /// An empty (never sampled) image of `width` x `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            sums: vec![Vec3::ZERO; n],
            counts: vec![0; n],
            cursor: 0,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Forgets every sample (the camera, the scene or the view changed).
    pub fn restart(&mut self) {
        self.sums.fill(Vec3::ZERO);
        self.counts.fill(0);
        self.cursor = 0;
    }

    /// Changes the size, forgetting every sample if it differs.
    pub fn resize(&mut self, width: u32, height: u32) {
        if (width, height) != (self.width, self.height) {
            *self = Self::new(width, height);
        }
    }

    /// Samples so far of pixel `(x, y)`, or `None` outside the image.
    pub fn sample_count(&self, x: u32, y: u32) -> Option<u32> {
        (x < self.width && y < self.height)
            .then(|| self.counts[y as usize * self.width as usize + x as usize])
    }

    /// The fewest samples any pixel has.
    pub fn min_samples(&self) -> u32 {
        self.counts.iter().copied().min().unwrap_or(0)
    }

    /// The mean linear value of pixel `(x, y)`, or `None` outside the image or before its
    /// first sample.
    pub fn mean(&self, x: u32, y: u32) -> Option<Vec3> {
        let n = self.sample_count(x, y).filter(|&n| n > 0)?;
        Some(self.sums[y as usize * self.width as usize + x as usize] / n as f32)
    }

    /// The next `count` rows (at least one) of a sweep down the image, starting where the
    /// last call stopped and starting over at the top after the bottom row; a range never
    /// wraps, so it may be shorter than asked at the bottom (the caller asks again if its
    /// budget allows). Empty for an empty image.
    pub fn next_rows(&mut self, count: u32) -> Range<u32> {
        if self.height == 0 {
            return 0..0;
        }
        if self.cursor >= self.height {
            self.cursor = 0;
        }
        let start = self.cursor;
        let end = start.saturating_add(count.max(1)).min(self.height);
        self.cursor = if end == self.height { 0 } else { end };
        start..end
    }

    /// `rows` (clamped to the image) cut into disjoint tiles of `rows_per_tile` rows (the
    /// last may be shorter), for tracing in parallel.
    pub fn tiles(&mut self, rows: Range<u32>, rows_per_tile: u32) -> Vec<ImageTile<'_>> {
        let start = rows.start.min(self.height);
        let end = rows.end.clamp(start, self.height);
        let (w, h) = (self.width, self.height);
        let per_tile = rows_per_tile.max(1);
        let (first, last) = (start as usize * w as usize, end as usize * w as usize);
        let chunk = per_tile as usize * (w as usize).max(1);
        self.sums[first..last]
            .chunks_mut(chunk)
            .zip(self.counts[first..last].chunks_mut(chunk))
            .zip((start..end).step_by(per_tile as usize))
            .map(|((sums, counts), row)| ImageTile {
                rows: row..(row + per_tile).min(end),
                width: w,
                height: h,
                sums,
                counts,
            })
            .collect()
    }

    /// The image as RGBA8, row by row from the top, written over `out`: each pixel's mean,
    /// times `exposure`, through `tonemap`, sRGB-encoded, alpha 255; pixels never sampled
    /// are transparent black, so a display can tell them from dark ones.
    pub fn resolve_rgba8(&self, tonemap: Tonemap, exposure: f32, out: &mut Vec<u8>) {
        out.clear();
        out.reserve(self.sums.len() * 4);
        for (&sum, &n) in self.sums.iter().zip(&self.counts) {
            if n == 0 {
                out.extend_from_slice(&[0; 4]);
                continue;
            }
            let c = tonemap.apply(sum * (exposure / n as f32));
            out.extend_from_slice(&[
                linear_to_srgb8(c.x),
                linear_to_srgb8(c.y),
                linear_to_srgb8(c.z),
                255,
            ]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_rows_once_and_accumulate() {
        let mut image = PreviewImage::new(3, 5);
        let tiles = image.tiles(1..5, 3);
        assert_eq!(
            tiles.iter().map(|t| t.rows()).collect::<Vec<_>>(),
            vec![1..4, 4..5]
        );
        for mut tile in tiles {
            for y in tile.rows() {
                for x in 0..3 {
                    tile.add_sample(x, y, Vec3::splat((x + 3 * y) as f32));
                    tile.add_sample(x, y, Vec3::NAN);
                }
            }
        }
        assert_eq!(image.mean(0, 0), None);
        assert_eq!(image.mean(2, 4), Some(Vec3::splat(7.0)));
        assert_eq!(image.min_samples(), 0);
        assert_eq!(image.sample_count(1, 3), Some(2));
        image.restart();
        assert_eq!(image.mean(2, 4), None);
        assert!(image.tiles(7..9, 2).is_empty());
    }

    #[test]
    fn sweeps_restart_at_the_top() {
        let mut image = PreviewImage::new(2, 5);
        assert_eq!(image.next_rows(2), 0..2);
        assert_eq!(image.next_rows(2), 2..4);
        assert_eq!(image.next_rows(2), 4..5);
        assert_eq!(image.next_rows(0), 0..1);
        assert_eq!(PreviewImage::new(2, 0).next_rows(4), 0..0);
    }
}
