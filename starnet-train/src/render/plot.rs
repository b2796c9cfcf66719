//! Line charts as PNG (coverage vs centers, AP vs GFLOPs, ...): axes with ticks and labels,
//! one polyline with markers per series, and a legend. Drawn with the bitmap font, so no font
//! file is needed.

use super::{Canvas, Rgb};

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

const PALETTE: [Rgb; 6] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
];
const INK: Rgb = [30, 30, 30];
const GRID: Rgb = [225, 225, 225];
const W: usize = 900;
const H: usize = 560;
/// Margins around the plotting area, pixels.
const LEFT: f32 = 80.0;
const RIGHT: f32 = 30.0;
const TOP: f32 = 50.0;
const BOTTOM: f32 = 70.0;

/// "Nice" tick values covering `[lo, hi]`.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    // Ticks as whole multiples of the step, not a running sum that drifts (0.30000000000000004).
    let first = (lo / step).ceil() as i64;
    (first..)
        .map(|k| k as f64 * step)
        .take_while(|t| *t <= hi + 1e-9 * span)
        .collect()
}

fn label(v: f64) -> String {
    if v.abs() >= 100.0 || v == v.round() {
        format!("{v:.0}")
    } else if v.abs() >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// The plot area: data ranges (x already on the log scale when `log_x`) and pixel size.
struct Axes {
    log_x: bool,
    x: (f64, f64),
    y: (f64, f64),
    pw: f32,
    ph: f32,
}

impl Axes {
    fn fx(&self, x: f64) -> f64 {
        if self.log_x { x.max(1e-12).log10() } else { x }
    }

    fn px(&self, x: f64) -> f32 {
        LEFT + ((self.fx(x) - self.x.0) / (self.x.1 - self.x.0)) as f32 * self.pw
    }

    fn py(&self, y: f64) -> f32 {
        TOP + self.ph - ((y - self.y.0) / (self.y.1 - self.y.0)) as f32 * self.ph
    }
}

impl LinePlot {
    /// Draws the chart.
    pub fn render(&self) -> Canvas {
        let mut c = Canvas::new(W, H, [255, 255, 255]);
        let axes = self.axes();
        self.draw_grid(&mut c, &axes);
        let (pw, ph) = (axes.pw, axes.ph);
        c.polygon(
            &[[LEFT, TOP], [LEFT + pw, TOP], [LEFT + pw, TOP + ph], [LEFT, TOP + ph]],
            INK,
            2,
        );
        // Titles.
        c.text(LEFT as i64, 4, &self.title, INK, 2);
        c.text(
            (LEFT + 0.5 * pw) as i64 - 6 * self.x_label.len() as i64,
            H as i64 - 28,
            &self.x_label,
            INK,
            2,
        );
        c.text(8, TOP as i64 - 20, &self.y_label, INK, 2);
        self.draw_curves(&mut c, &axes);
        c
    }

    /// The data ranges (y padded by 5 %, or the given range) and the plot area.
    fn axes(&self) -> Axes {
        let mut axes = Axes {
            log_x: self.log_x,
            x: (0.0, 1.0),
            y: (0.0, 1.0),
            pw: W as f32 - LEFT - RIGHT,
            ph: H as f32 - TOP - BOTTOM,
        };
        let all: Vec<(f64, f64)> = self.series.iter().flat_map(|s| s.points.iter().copied()).collect();
        let (mut x0, mut x1) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(axes.fx(p.0)), b.max(axes.fx(p.0)))
        });
        if !x0.is_finite() || x0 == x1 {
            (x0, x1) = (x0.min(0.0) - 1.0, x1.max(0.0) + 1.0);
        }
        axes.x = (x0, x1);
        axes.y = self.y_range.unwrap_or_else(|| {
            let (a, b) = all
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
            if a.is_finite() && a < b {
                (a - 0.05 * (b - a), b + 0.05 * (b - a))
            } else {
                (0.0, 1.0)
            }
        });
        axes
    }

    /// Grid lines with their tick labels.
    fn draw_grid(&self, c: &mut Canvas, axes: &Axes) {
        for t in ticks(axes.y.0, axes.y.1) {
            let y = axes.py(t);
            c.line([LEFT, y], [LEFT + axes.pw, y], GRID, 1);
            let s = label(t);
            c.text(LEFT as i64 - 8 - 12 * s.len() as i64, y as i64 - 7, &s, INK, 2);
        }
        for t in self.x_ticks(axes) {
            let x = axes.px(t);
            c.line([x, TOP], [x, TOP + axes.ph], GRID, 1);
            let s = label(t);
            c.text(x as i64 - 6 * s.len() as i64, (TOP + axes.ph) as i64 + 10, &s, INK, 2);
        }
    }

    /// Ticks of a log x axis at the data's x values when they are few and spread (center
    /// counts), else at 1, 2, 5 × 10^k (GFLOP, milliseconds); linear ticks otherwise.
    fn x_ticks(&self, axes: &Axes) -> Vec<f64> {
        let (x0, x1) = axes.x;
        if !self.log_x {
            return ticks(x0, x1);
        }
        let mut v: Vec<f64> = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        let spread = v.windows(2).all(|w| w[1] >= 1.5 * w[0]);
        if v.len() <= 8 && spread {
            return v;
        }
        let (lo, hi) = (10f64.powf(x0), 10f64.powf(x1));
        (x0.floor() as i32..=x1.ceil() as i32)
            .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
            .filter(|t| (lo * 0.999..=hi * 1.001).contains(t))
            .collect()
    }

    /// Every series and its legend entry.
    fn draw_curves(&self, c: &mut Canvas, axes: &Axes) {
        // Wide enough for the longest name (12 px per character at scale 2).
        let longest = self.series.iter().map(|s| s.name.chars().count()).max().unwrap_or(0);
        let lx = (LEFT + axes.pw) as i64 - (44 + 12 * longest as i64).max(220);
        for (k, s) in self.series.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let pts: Vec<[f32; 2]> = s.points.iter().map(|&(x, y)| [axes.px(x), axes.py(y)]).collect();
            // Dense curves (training logs) are lines only; sparse ones get a marker per point.
            let dense = pts.len() > 60;
            for w in pts.windows(2) {
                c.line(w[0], w[1], colour, if dense { 1 } else { 3 });
            }
            for p in pts.iter().filter(|_| !dense) {
                let (x, y) = (p[0] as i64, p[1] as i64);
                c.fill_rect(x - 4, y - 4, x + 5, y + 5, colour);
            }
            // Bottom right: curves of coverage and accuracy climb towards the top right.
            let ly = (TOP + axes.ph) as i64 - 12 - 24 * (self.series.len() - k) as i64;
            c.fill_rect(lx, ly + 3, lx + 24, ly + 9, colour);
            c.text(lx + 32, ly, &s.name, INK, 2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ticks() {
        assert_eq!(ticks(0.0, 100.0), vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        let t = ticks(0.13, 0.61);
        assert_eq!(t.len(), 5);
        assert!(
            t.iter()
                .zip([0.2, 0.3, 0.4, 0.5, 0.6])
                .all(|(a, b)| (a - b).abs() < 1e-12),
            "{t:?}"
        );
    }

    #[test]
    fn curves_are_drawn_where_the_data_says() {
        let plot = LinePlot {
            title: "T".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![(16.0, 0.0), (1024.0, 100.0)],
            }],
            log_x: true,
            y_range: Some((0.0, 100.0)),
        };
        let c = plot.render();
        // The first point sits at the plot's bottom-left corner, the last at its top-right.
        assert_eq!(c.get(LEFT as i64, (H as f32 - BOTTOM) as i64), Some(PALETTE[0]));
        assert_eq!(c.get((W as f32 - RIGHT) as i64 - 2, TOP as i64 + 2), Some(PALETTE[0]));
    }
}
