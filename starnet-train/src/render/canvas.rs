//! An RGB raster with the few primitives the renderers need (pixels, thick lines, rectangles,
//! bitmap text) and an atomic PNG writer. Coordinates are pixels, origin top-left, y down.

use super::font;
use crate::{Result, TrainError};
use std::path::Path;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// An RGB image in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<Rgb>,
}

impl Canvas {
    /// A `width × height` canvas filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Self {
        Self {
            width,
            height,
            pixels: vec![background; width * height],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The colour at `(x, y)`, `None` outside.
    pub fn get(&self, x: i64, y: i64) -> Option<Rgb> {
        self.index(x, y).map(|i| self.pixels[i])
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height)
            .then(|| y as usize * self.width + x as usize)
    }

    /// Sets one pixel; outside the canvas it is a no-op (shapes may cross the border).
    pub fn put(&mut self, x: i64, y: i64, c: Rgb) {
        if let Some(i) = self.index(x, y) {
            self.pixels[i] = c;
        }
    }

    /// Fills the rectangle `[x0, x1) × [y0, y1)`.
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: Rgb) {
        for y in y0.max(0)..y1.min(self.height as i64) {
            for x in x0.max(0)..x1.min(self.width as i64) {
                self.put(x, y, c);
            }
        }
    }

    /// A line of the given thickness from `a` to `b` (sub-pixel endpoints).
    pub fn line(&mut self, a: [f32; 2], b: [f32; 2], c: Rgb, thickness: u32) {
        let steps = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil() as usize).max(1);
        let r = thickness as i64 / 2;
        let lo = -r;
        let hi = thickness as i64 - 1 - r;
        for s in 0..=steps {
            let t = s as f32 / steps as f32;
            let (x, y) = (
                (a[0] + t * (b[0] - a[0])).round() as i64,
                (a[1] + t * (b[1] - a[1])).round() as i64,
            );
            for dy in lo..=hi {
                for dx in lo..=hi {
                    self.put(x + dx, y + dy, c);
                }
            }
        }
    }

    /// A closed polygon outline.
    pub fn polygon(&mut self, pts: &[[f32; 2]], c: Rgb, thickness: u32) {
        for i in 0..pts.len() {
            self.line(pts[i], pts[(i + 1) % pts.len()], c, thickness);
        }
    }

    /// Text with its top-left corner at `(x, y)`, each font pixel drawn `scale × scale`.
    /// Returns the width drawn, in pixels.
    pub fn text(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: usize) -> i64 {
        let sc = scale as i64;
        for (k, ch) in s.chars().enumerate() {
            let ox = x + (k * font::ADVANCE * scale) as i64;
            for (row, bits) in font::glyph(ch).iter().enumerate() {
                for col in 0..5 {
                    if bits >> (4 - col) & 1 == 1 {
                        let (px, py) = (ox + col * sc, y + row as i64 * sc);
                        self.fill_rect(px, py, px + sc, py + sc, c);
                    }
                }
            }
        }
        (s.chars().count() * font::ADVANCE * scale) as i64
    }

    /// The image as PNG bytes (8-bit RGB).
    pub fn encode_png(&self) -> std::result::Result<Vec<u8>, png::EncodingError> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header()?;
        writer.write_image_data(self.pixels.as_flattened())?;
        writer.finish()?;
        Ok(out)
    }

    /// Writes a PNG atomically (temp file + rename).
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let bytes = self.encode_png().map_err(|e| TrainError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Ok(starnet_data::io::atomic_write(path, &bytes)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: Rgb = [255, 255, 255];

    #[test]
    fn line_covers_both_endpoints_and_clips() {
        let mut c = Canvas::new(10, 10, [0; 3]);
        c.line([1.0, 1.0], [8.0, 5.0], W, 1);
        assert_eq!(c.get(1, 1), Some(W));
        assert_eq!(c.get(8, 5), Some(W));
        assert_eq!(c.get(1, 8), Some([0; 3]));
        c.line([-5.0, -5.0], [20.0, 20.0], W, 3); // crosses the border: no panic
        assert_eq!(c.get(9, 9), Some(W));
    }

    #[test]
    fn text_draws_the_glyph_bits() {
        let mut c = Canvas::new(20, 10, [0; 3]);
        let w = c.text(0, 0, "1", W, 1);
        assert_eq!(w, 6);
        let lit = (0..10)
            .flat_map(|y| (0..20).map(move |x| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some(W))
            .count();
        let want: u32 = font::glyph('1').iter().map(|r| r.count_ones()).sum();
        assert_eq!(lit as u32, want);
    }

    #[test]
    fn png_round_trip() {
        let mut c = Canvas::new(4, 3, [1, 2, 3]);
        c.put(2, 1, [200, 100, 50]);
        let bytes = c.encode_png().unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (4, 3));
        assert_eq!(&buf[(4 + 2) * 3..(4 + 2) * 3 + 3], &[200, 100, 50]);
        assert_eq!(&buf[0..3], &[1, 2, 3]);
    }
}
