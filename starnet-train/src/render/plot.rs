//! Line charts as PNG (coverage vs centers, AP vs GFLOPs, ...) on `plotters`: a titled chart
//! with a grid, minor ticks and axis titles, one line (with markers when sparse) per series, and
//! the legend beside the plot, outside the data.

use super::font::FAMILY;
use super::{Canvas, Rgb};
use crate::Result;
use plotters::coord::Shift;
use plotters::coord::combinators::{BindKeyPoints, LogCoord, WithKeyPoints};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::error::Error;
use std::ops::Range;

/// One named curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points `(x, y)` in data units, drawn in order.
    pub points: Vec<(f64, f64)>,
}

/// A chart description.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    /// Title above the chart.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
    /// Logarithmic x axis (ticks at the data's x values).
    pub log_x: bool,
    /// y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
}

/// Matplotlib's tab10 and two light tints: twelve series (three models × three NMS modes,
/// say) each in a colour of its own.
const PALETTE: [Rgb; 12] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
    [174, 199, 232],
    [255, 187, 120],
];
const INK: RGBColor = RGBColor(30, 30, 30);
const W: usize = 960;
const H: usize = 560;
/// Series with more points than this (training logs) are drawn as lines without markers.
const DENSE: usize = 60;
/// Gap between the plot and the legend, and the legend's inner margin, pixels.
const LEGEND_PAD: i32 = 16;

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Drawn = std::result::Result<(), Box<dyn Error>>;

fn colour(k: usize) -> RGBColor {
    let [r, g, b] = PALETTE[k % PALETTE.len()];
    RGBColor(r, g, b)
}

/// A tick label: as few digits as the value needs.
fn label(v: f64) -> String {
    if v.abs() >= 100.0 || v == v.round() {
        format!("{v:.0}")
    } else if v.abs() >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

impl LinePlot {
    /// Draws the chart.
    pub fn render(&self) -> Result<Canvas> {
        let mut c = Canvas::new(W, H, [255, 255, 255]);
        c.draw(|root| self.paint(root))?;
        Ok(c)
    }

    fn paint(&self, root: &Area) -> Drawn {
        let legend_w = self.legend_width(root)?;
        let (plot, legend) = root.split_horizontally(W as i32 - legend_w);
        let (x, y) = (self.x_range(), self.y_range());
        match self.log_x {
            true => self.chart(&plot, self.log_axis(x), y)?,
            false => self.chart(&plot, x, y)?,
        }
        self.legend(&legend)
    }

    /// The x data range, padded so the outermost markers stay inside the frame.
    fn x_range(&self) -> Range<f64> {
        let xs = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        match (lo.is_finite() && lo < hi, self.log_x) {
            (true, true) => lo / 1.08..hi * 1.08,
            (true, false) => lo - 0.02 * (hi - lo)..hi + 0.02 * (hi - lo),
            (false, true) => lo.max(1e-3) / 2.0..lo.max(1e-3) * 2.0,
            (false, false) => lo.min(0.0) - 1.0..hi.max(0.0) + 1.0,
        }
    }

    /// The given y range, or the data's padded by 5 %.
    fn y_range(&self) -> Range<f64> {
        if let Some((a, b)) = self.y_range {
            return a..b;
        }
        let ys = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        let (a, b) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| (a.min(y), b.max(y)));
        if a.is_finite() && a < b {
            a - 0.05 * (b - a)..b + 0.05 * (b - a)
        } else {
            0.0..1.0
        }
    }

    /// A log x axis labelled at the data's x values when they are few and spread (center
    /// counts), else at 1, 2, 5 × 10^k (GFLOP, milliseconds); the other multiples as minor ticks.
    fn log_axis(&self, x: Range<f64>) -> WithKeyPoints<LogCoord<f64>> {
        let mut v: Vec<f64> = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        let decades = || (x.start.log10().floor() as i32..=x.end.log10().ceil() as i32).map(|k| 10f64.powi(k));
        let within = |t: &f64| x.contains(t);
        let spread = v.len() <= 8 && v.windows(2).all(|w| w[1] >= 1.5 * w[0]);
        // 1, 2, 5 × 10^k; on a short axis more multiples, until four labels.
        let at = |ms: &[f64]| -> Vec<f64> {
            decades()
                .flat_map(|d| ms.iter().map(move |m| m * d))
                .filter(within)
                .collect()
        };
        let major: Vec<f64> = match spread {
            true => v,
            false => [
                &[1.0, 2.0, 5.0][..],
                &[1.0, 2.0, 3.0, 5.0],
                &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
            ]
            .into_iter()
            .map(at)
            .find(|t| t.len() >= 4)
            .unwrap_or_else(|| at(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])),
        };
        let minor: Vec<f64> = decades()
            .flat_map(|d| (1..10).map(move |m| m as f64 * d))
            .filter(within)
            .collect();
        x.log_scale().with_key_points(major).with_light_points(minor)
    }

    fn chart<X>(&self, area: &Area, x: X, y: Range<f64>) -> Drawn
    where
        X: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
    {
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FAMILY, 22).into_font().color(&INK))
            .margin(14)
            .x_label_area_size(52)
            .y_label_area_size(70)
            .build_cartesian_2d(x, y)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_label_formatter(&|v| label(*v))
            .y_label_formatter(&|v| label(*v))
            .label_style((FAMILY, 14).into_font().color(&INK))
            .axis_desc_style((FAMILY, 16).into_font().color(&INK))
            .axis_style(INK.stroke_width(1))
            .bold_line_style(RGBColor(205, 205, 205).stroke_width(1))
            .light_line_style(RGBColor(238, 238, 238).stroke_width(1))
            .max_light_lines(1)
            .draw()?;
        for (k, s) in self.series.iter().enumerate() {
            // Dense curves (training logs) are lines only; sparse ones get a marker per point.
            let dense = s.points.len() > DENSE;
            let line = colour(k).stroke_width(if dense { 1 } else { 2 });
            chart.draw_series(LineSeries::new(s.points.iter().copied(), line))?;
            if !dense {
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 4, colour(k).filled())))?;
            }
        }
        Ok(())
    }

    /// Wide enough for the longest name beside its swatch.
    fn legend_width(&self, root: &Area) -> std::result::Result<i32, Box<dyn Error>> {
        let font = (FAMILY, 15).into_font();
        let mut widest = 0;
        for s in &self.series {
            widest = widest.max(root.estimate_text_size(&s.name, &font.clone().into_text_style(root))?.0 as i32);
        }
        Ok((widest + 36 + 3 * LEGEND_PAD).clamp(140, W as i32 / 2))
    }

    /// One swatch and name per series, top to bottom, level with the plot's top.
    fn legend(&self, area: &Area) -> Drawn {
        let font = (FAMILY, 15).into_font().color(&INK);
        for (k, s) in self.series.iter().enumerate() {
            let (x, y) = (LEGEND_PAD, 56 + 26 * k as i32);
            area.draw(&PathElement::new(vec![(x, y), (x + 24, y)], colour(k).stroke_width(3)))?;
            if s.points.len() <= DENSE {
                area.draw(&Circle::new((x + 12, y), 4, colour(k).filled()))?;
            }
            area.draw(&Text::new(s.name.as_str(), (x + 32, y - 8), font.clone()))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot(names: &[&str]) -> LinePlot {
        LinePlot {
            title: "Title".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: names
                .iter()
                .enumerate()
                .map(|(k, n)| Series {
                    name: n.to_string(),
                    points: vec![
                        (16.0, 10.0 * k as f64),
                        (128.0, 50.0),
                        (1024.0, 100.0 - 10.0 * k as f64),
                    ],
                })
                .collect(),
            log_x: true,
            y_range: Some((0.0, 100.0)),
        }
    }

    fn pixels_of(c: &Canvas, rgb: Rgb) -> Vec<(i64, i64)> {
        (0..c.height() as i64)
            .flat_map(|y| (0..c.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some(rgb))
            .collect()
    }

    #[test]
    fn the_curve_rises_left_to_right_and_the_legend_sits_beside_it() {
        let p = plot(&["first series", "second"]);
        let c = p.render().unwrap();
        assert_eq!((c.width(), c.height()), (W, H));
        // Where the plot ends and the legend begins.
        let mut probe = Canvas::new(W, H, [255; 3]);
        let mut legend_x = 0;
        probe
            .draw(|root| {
                legend_x = W as i64 - p.legend_width(root)? as i64;
                Ok(())
            })
            .unwrap();
        let first = pixels_of(&c, PALETTE[0]);
        let plotted: Vec<&(i64, i64)> = first.iter().filter(|p| p.0 < legend_x).collect();
        let legend: Vec<&(i64, i64)> = first.iter().filter(|p| p.0 >= legend_x).collect();
        let left = plotted.iter().min_by_key(|p| p.0).unwrap();
        let right = plotted.iter().max_by_key(|p| p.0).unwrap();
        assert!(left.1 > right.1 + 300, "from {left:?} to {right:?}: y grows downwards");
        assert!(!legend.is_empty(), "the swatch");
        // The second series starts higher and ends lower.
        let second = pixels_of(&c, PALETTE[1]);
        let left2 = second.iter().filter(|p| p.0 < legend_x).min_by_key(|p| p.0).unwrap();
        assert!(left2.1 < left.1, "{left2:?} above {left:?}");
        // The names are written in the legend strip, not over the data.
        let ink = |x: i64, y: i64| c.get(x, y).is_some_and(|[r, g, b]| r < 90 && g < 90 && b < 90);
        assert!((legend_x..W as i64).any(|x| (40..120).any(|y| ink(x, y))));
    }

    #[test]
    fn twelve_series_are_drawn_in_twelve_colours() {
        let names: Vec<String> = (0..12).map(|k| format!("s{k}")).collect();
        let p = plot(&names.iter().map(String::as_str).collect::<Vec<_>>());
        let c = p.render().unwrap();
        for (k, rgb) in PALETTE.iter().enumerate() {
            assert!(!pixels_of(&c, *rgb).is_empty(), "series {k} is drawn");
            // Far enough from every other (and from the ink) to tell apart.
            let far = |o: &Rgb| {
                rgb.iter()
                    .zip(o)
                    .map(|(a, b)| (*a as i32 - *b as i32).abs())
                    .sum::<i32>()
                    > 60
            };
            assert!(PALETTE.iter().enumerate().all(|(j, o)| j == k || far(o)), "colour {k}");
            assert!(far(&[30, 30, 30]), "colour {k} against the ink");
        }
    }

    #[test]
    fn log_ticks_fall_on_few_spread_values_or_on_1_2_5() {
        let p = plot(&["a"]);
        let few = p.log_axis(p.x_range());
        assert_eq!(few.bold_points(), &[16.0, 128.0, 1024.0]);
        let mut dense = plot(&["a"]);
        dense.series[0].points = (0..20).map(|i| (0.3 + i as f64 * 0.4, 1.0)).collect();
        let ticks = dense.log_axis(dense.x_range()).bold_points().to_vec();
        assert_eq!(ticks, vec![0.5, 1.0, 2.0, 5.0]);
        // 5.4 to 50 ms: 10 and 20 (or 10, 20, 30) are too few, so every multiple.
        dense.series[0].points = vec![
            (5.8, 1.0),
            (7.0, 2.0),
            (9.6, 3.0),
            (17.6, 4.0),
            (45.9, 5.0),
            (11.0, 6.0),
        ];
        let ticks = dense.log_axis(dense.x_range()).bold_points().to_vec();
        assert_eq!(ticks, vec![6.0, 7.0, 8.0, 9.0, 10.0, 20.0, 30.0, 40.0]);
    }

    #[test]
    fn tick_labels_use_the_digits_needed() {
        assert_eq!(label(256.0), "256");
        assert_eq!(label(2.5), "2.5");
        assert_eq!(label(0.25), "0.25");
    }
}
