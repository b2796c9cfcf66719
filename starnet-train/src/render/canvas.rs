//! The RGB image the renderers draw into with `plotters`, and its atomic PNG writer.
//! Coordinates are pixels, origin top-left, y down.

use super::font;
use crate::{Result, TrainError};
use plotters::coord::Shift;
use plotters::prelude::{BitMapBackend, DrawingArea, IntoDrawingArea};
use std::path::Path;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// An RGB image in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    /// A `width × height` canvas filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Self {
        Self {
            width,
            height,
            rgb: background.repeat(width * height),
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
        let inside = x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height;
        inside.then(|| {
            let i = 3 * (y as usize * self.width + x as usize);
            [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
        })
    }

    /// Runs `paint` on a `plotters` drawing area over the whole canvas (the shipped font
    /// registered first).
    pub fn draw<F>(&mut self, paint: F) -> Result<()>
    where
        F: FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> std::result::Result<(), Box<dyn std::error::Error>>,
    {
        font::register();
        let size = (self.width as u32, self.height as u32);
        let area = BitMapBackend::with_buffer(&mut self.rgb, size).into_drawing_area();
        paint(&area)
            .and_then(|()| area.present().map_err(Into::into))
            .map_err(|e| TrainError::Draw(e.to_string()))
    }

    /// The image as PNG bytes (8-bit RGB).
    pub fn encode_png(&self) -> std::result::Result<Vec<u8>, png::EncodingError> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header()?;
        writer.write_image_data(&self.rgb)?;
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
    use plotters::prelude::{RGBColor, Rectangle};
    use plotters::style::Color;

    #[test]
    fn drawing_lands_on_the_pixels_named() {
        let mut c = Canvas::new(8, 6, [0; 3]);
        c.draw(|a| {
            a.draw(&Rectangle::new([(2, 1), (4, 3)], RGBColor(200, 100, 50).filled()))?;
            Ok(())
        })
        .unwrap();
        assert_eq!(c.get(3, 2), Some([200, 100, 50]));
        assert_eq!(c.get(6, 2), Some([0; 3]));
        assert_eq!(c.get(8, 0), None);
    }

    #[test]
    fn png_round_trip() {
        let mut c = Canvas::new(4, 3, [1, 2, 3]);
        c.draw(|a| {
            a.draw_pixel((2, 1), &RGBColor(200, 100, 50))?;
            Ok(())
        })
        .unwrap();
        let bytes = c.encode_png().unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (4, 3));
        assert_eq!(&buf[(4 + 2) * 3..(4 + 2) * 3 + 3], &[200, 100, 50]);
        assert_eq!(&buf[0..3], &[1, 2, 3]);
    }
}
