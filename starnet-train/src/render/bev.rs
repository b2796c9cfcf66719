//! `starnet render`: a bird's-eye view of a frame. Points shaded by height, ground-truth boxes
//! in green and predictions in orange, each with a heading mark (a line from the centre to the
//! front edge), range rings every 10 m, and a metric scale bar. x (forward) points up the
//! image and y (left) to the left, so the picture is what a viewer above the car would see.

use super::font::FAMILY;
use super::frame_scene::{RenderOptions, SceneBox, frame_scene};
use super::{Canvas, Rgb};
use crate::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use starnet_data::Point;
use starnet_data::kitti::KittiDataset;
use starnet_data::sampling::Centers;

/// Extent and resolution of a bird's-eye view (LiDAR-frame metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BevOptions {
    /// Forward extent `[x_min, x_max]`: the bottom and top of the image.
    pub x: [f32; 2],
    /// Lateral extent `[y_min, y_max]`: the right and left of the image.
    pub y: [f32; 2],
    /// Pixels per metre.
    pub px_per_m: f32,
}

impl BevOptions {
    /// The camera's side of the car, as KITTI labels it: x ∈ [−0.1 r, r], y ∈ [−0.55 r, 0.55 r].
    pub fn front(range_m: f32, px_per_m: f32) -> Self {
        Self {
            x: [-0.1 * range_m, range_m],
            y: [-0.55 * range_m, 0.55 * range_m],
            px_per_m,
        }
    }

    /// All around the sensor: x, y ∈ [−r, r].
    pub fn around(range_m: f32, px_per_m: f32) -> Self {
        Self {
            x: [-range_m, range_m],
            y: [-range_m, range_m],
            px_per_m,
        }
    }

    /// Image `(width, height)` in pixels.
    pub fn size(&self) -> (usize, usize) {
        let px = |r: [f32; 2]| ((r[1] - r[0]) * self.px_per_m).round() as usize;
        (px(self.y), px(self.x))
    }

    /// LiDAR (x, y) → pixel (column, row).
    fn pixel(&self, x: f32, y: f32) -> [f32; 2] {
        [(self.y[1] - y) * self.px_per_m, (self.x[1] - x) * self.px_per_m]
    }

    /// Distance from the sensor to the farthest corner of the view.
    pub fn reach(&self) -> f32 {
        let fx = self.x[0].abs().max(self.x[1].abs());
        let fy = self.y[0].abs().max(self.y[1].abs());
        fx.hypot(fy)
    }
}

impl Default for BevOptions {
    fn default() -> Self {
        Self::front(80.0, 10.0)
    }
}

const BACKGROUND: Rgb = [14, 16, 22];
const RING: Rgb = [48, 52, 64];
pub(super) const GT: Rgb = [60, 230, 100];
pub(super) const PRED: Rgb = [255, 140, 20];
const TEXT: Rgb = [230, 230, 230];
/// Colour of sampled centers.
pub const CENTER: Rgb = [255, 60, 220];
/// Colour of centers seeded from the previous frame's detections.
pub const SEEDED: Rgb = [40, 220, 255];

/// Height colour: blue at the road (z ≈ −1.7 m), through green, to red at +1 m and above.
pub(super) fn height_colour(z: f32) -> Rgb {
    const STOPS: [(f32, [f32; 3]); 5] = [
        (-2.2, [40.0, 60.0, 200.0]),
        (-1.4, [30.0, 170.0, 230.0]),
        (-0.6, [60.0, 220.0, 120.0]),
        (0.2, [240.0, 220.0, 60.0]),
        (1.0, [240.0, 70.0, 50.0]),
    ];
    let z = z.clamp(STOPS[0].0, STOPS[4].0);
    let i = STOPS.windows(2).position(|w| z <= w[1].0).unwrap_or(3);
    let ((z0, c0), (z1, c1)) = (STOPS[i], STOPS[i + 1]);
    let t = (z - z0) / (z1 - z0);
    std::array::from_fn(|k| (c0[k] + t * (c1[k] - c0[k])) as u8)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Drawn = std::result::Result<(), Box<dyn std::error::Error>>;

fn rgb([r, g, b]: Rgb) -> RGBColor {
    RGBColor(r, g, b)
}

fn pixel_i(opts: &BevOptions, x: f32, y: f32) -> (i32, i32) {
    let [u, v] = opts.pixel(x, y);
    (u.round() as i32, v.round() as i32)
}

/// The box's outline, a heading mark from its centre to the middle of its front edge, and its
/// class (and score) above it.
fn draw_box(area: &Area, opts: &BevOptions, bx: &SceneBox, colour: Rgb) -> Drawn {
    let b = &bx.b;
    let corners = b.corners_bev().map(|[x, y]| pixel_i(opts, x, y));
    let style = rgb(colour).stroke_width(2);
    let mut outline = corners.to_vec();
    outline.push(corners[0]);
    area.draw(&PathElement::new(outline, style))?;
    let front = ((corners[0].0 + corners[1].0) / 2, (corners[0].1 + corners[1].1) / 2);
    area.draw(&PathElement::new(vec![pixel_i(opts, b.x, b.y), front], style))?;
    let label = match bx.score {
        Some(s) => format!("{} {s:.2}", bx.class),
        None => bx.class.to_string(),
    };
    let top = corners
        .iter()
        .fold((i32::MAX, i32::MAX), |m, p| (m.0.min(p.0), m.1.min(p.1)));
    let font = (FAMILY, 12).into_font().color(&rgb(colour));
    area.draw(&Text::new(label, (top.0, top.1 - 15), font))?;
    Ok(())
}

/// Range rings every 10 m around the sensor.
fn draw_rings(area: &Area, opts: &BevOptions) -> Drawn {
    let centre = pixel_i(opts, 0.0, 0.0);
    let mut r = 10.0;
    while r <= opts.reach() {
        let radius = (r * opts.px_per_m).round() as i32;
        area.draw(&Circle::new(centre, radius, rgb(RING).stroke_width(1)))?;
        r += 10.0;
    }
    Ok(())
}

/// Sensor arrow, title, legend and scale bar, drawn last so nothing covers them.
fn draw_overlay(area: &Area, opts: &BevOptions, title: &str, has_preds: bool) -> Drawn {
    let (cx, cy) = pixel_i(opts, 0.0, 0.0);
    let ink = rgb(TEXT).stroke_width(2);
    area.draw(&PathElement::new(vec![(cx, cy + 6), (cx, cy - 8)], ink))?;
    area.draw(&PathElement::new(
        vec![(cx - 4, cy - 4), (cx, cy - 8), (cx + 4, cy - 4)],
        ink,
    ))?;
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    // Long titles (augmented frames) drop to a smaller size rather than run off the image.
    let mut title_font = (FAMILY, 17).into_font();
    let mut title_w = area
        .estimate_text_size(title, &title_font.clone().into_text_style(area))?
        .0 as i32;
    if title_w + 20 > w {
        title_font = (FAMILY, 12).into_font();
        title_w = area
            .estimate_text_size(title, &title_font.clone().into_text_style(area))?
            .0 as i32;
    }
    area.draw(&Rectangle::new(
        [(0, 0), ((title_w + 20).max(260).min(w), 54)],
        rgb(BACKGROUND).filled(),
    ))?;
    area.draw(&Text::new(title, (10, 8), title_font.color(&rgb(TEXT))))?;
    let legend = (FAMILY, 15).into_font();
    area.draw(&Text::new("ground truth", (10, 31), legend.color(&rgb(GT))))?;
    if has_preds {
        let x = 10
            + area
                .estimate_text_size("ground truth", &legend.clone().into_text_style(area))?
                .0 as i32
            + 16;
        area.draw(&Text::new("prediction", (x, 31), legend.color(&rgb(PRED))))?;
    }
    // A 10 m scale bar, bottom left.
    let len = (10.0 * opts.px_per_m).round() as i32;
    area.draw(&Rectangle::new(
        [(0, h - 36), ((len + 80).min(w), h)],
        rgb(BACKGROUND).filled(),
    ))?;
    area.draw(&PathElement::new(
        vec![(10, h - 20), (10 + len, h - 20)],
        rgb(TEXT).stroke_width(3),
    ))?;
    for x in [10, 10 + len] {
        area.draw(&PathElement::new(vec![(x, h - 26), (x, h - 14)], ink))?;
    }
    area.draw(&Text::new("10 m", (len + 18, h - 28), legend.color(&rgb(TEXT))))?;
    Ok(())
}

/// Draws a bird's-eye view.
pub fn render_bev(
    points: &[Point],
    gt: &[SceneBox],
    preds: &[SceneBox],
    opts: &BevOptions,
    title: &str,
) -> Result<Canvas> {
    let (w, h) = opts.size();
    let mut canvas = Canvas::new(w, h, BACKGROUND);
    canvas.draw(|area| {
        draw_rings(area, opts)?;
        for p in points {
            let (u, v) = pixel_i(opts, p[0], p[1]);
            area.draw_pixel((u, v), &rgb(height_colour(p[2])))?;
        }
        for b in gt {
            draw_box(area, opts, b, GT)?;
        }
        for b in preds {
            draw_box(area, opts, b, PRED)?;
        }
        draw_overlay(area, opts, title, !preds.is_empty())
    })?;
    Ok(canvas)
}

/// Centers as squares: the first `num_seeded` larger and in [`SEEDED`], drawn last so FPS
/// centers never hide them.
fn draw_center_marks(canvas: &mut Canvas, centers: &Centers, opts: &BevOptions) -> Result<()> {
    canvas.draw(|area| {
        for (i, c) in centers.xyz.iter().enumerate().rev() {
            let (u, v) = pixel_i(opts, c[0], c[1]);
            let (r, colour) = if i < centers.num_seeded {
                (3, SEEDED)
            } else {
                (2, CENTER)
            };
            area.draw(&Rectangle::new([(u - r, v - r), (u + r, v + r)], rgb(colour).filled()))?;
        }
        Ok(())
    })
}

/// Loads frame `id` of `dataset` and draws it with the extras `extra` asks for
/// ([`frame_scene`]).
pub fn render_frame(dataset: &KittiDataset, id: &str, extra: &RenderOptions, opts: &BevOptions) -> Result<Canvas> {
    let scene = frame_scene(dataset, id, extra, opts.reach())?;
    let mut canvas = render_bev(&scene.points, &scene.gt, &scene.predictions, opts, &scene.title)?;
    draw_center_marks(&mut canvas, &scene.centers, opts)?;
    Ok(canvas)
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::Box3d;
    use starnet_data::kitti::ObjectClass;

    fn count(c: &Canvas, colour: Rgb) -> usize {
        (0..c.height() as i64)
            .flat_map(|y| (0..c.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some(colour))
            .count()
    }

    #[test]
    fn points_and_boxes_land_where_the_axes_say() {
        let opts = BevOptions::around(20.0, 10.0);
        // A point 10 m ahead and 5 m to the left: column (20 − 5)·10 = 150, row (20 − 10)·10 = 100.
        let pts = [[10.0, 5.0, -1.7, 0.2]];
        let b = SceneBox {
            class: ObjectClass::Car,
            b: Box3d::new(-10.0, -10.0, -1.0, 4.0, 2.0, 1.5, 0.0),
            score: None,
        };
        let p = SceneBox { score: Some(0.5), ..b };
        let c = render_bev(&pts, &[b], &[], &opts, "T").unwrap();
        assert_eq!((c.width(), c.height()), (400, 400));
        assert_eq!(BevOptions::front(100.0, 2.0).size(), (220, 220));
        assert_eq!(c.get(150, 100), Some(height_colour(-1.7)));
        // The box spans x ∈ [−12, −8], y ∈ [−11, −9]: rows 280..320, columns 290..310.
        assert_eq!(c.get(300, 280), Some(GT)); // front edge centre (heading mark end)
        assert_eq!(c.get(290, 300), Some(GT));
        assert_ne!(c.get(295, 305), Some(GT)); // inside, off the edges and the heading mark
        assert_eq!(count(&c, PRED), 0);
        let with_pred = render_bev(&pts, &[b], &[p], &opts, "T").unwrap();
        assert!(count(&with_pred, PRED) > 100);
    }

    #[test]
    fn height_colour_is_monotone_in_red() {
        assert!(height_colour(-2.0)[0] < height_colour(0.5)[0]);
        assert_eq!(height_colour(-10.0), height_colour(-2.2));
        assert_eq!(height_colour(10.0), [240, 70, 50]);
    }
}
