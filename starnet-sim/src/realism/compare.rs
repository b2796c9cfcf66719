//! Two reports side by side: every cell reads `A / B`.

use super::{CarBin, END_ZONE_M, FIT_MIN_POINTS, RANGE_EDGES_M, RealismReport, ReflectanceBin};
use serde::{Deserialize, Serialize};
use std::fmt;

/// One figure of both folders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComparisonRow {
    /// What is measured.
    pub statistic: String,
    /// Its value on the first folder.
    pub a: f64,
    /// Its value on the second.
    pub b: f64,
}

/// Two folders' reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RealismComparison {
    /// The first folder's (the simulator's, say).
    pub a: RealismReport,
    /// The second's (real scans).
    pub b: RealismReport,
}

fn pair(a: f64, b: f64, digits: usize) -> String {
    format!("{a:.digits$} / {b:.digits$}")
}

/// Picks one per-frame spread from a report.
type Spread = fn(&RealismReport) -> super::Percentiles;

/// The per-frame spreads ([`super::FrameSpreads`]) as p10 / p50 / p90 rows.
fn spread_rows(a: &RealismReport, b: &RealismReport) -> Vec<ComparisonRow> {
    let stats: [(&str, Spread); 4] = [
        ("car-sized background clusters", |r| r.spreads.car_sized_clusters),
        ("background volumetric (%)", |r| r.spreads.volumetric_percent),
        ("background planar vertical (%)", |r| r.spreads.vertical_percent),
        ("off-road ground above the road, p90 (m)", |r| r.spreads.off_road_p90),
    ];
    let mut rows = Vec::new();
    for (name, f) in stats {
        for (q, pick) in [("p10", 0), ("p50", 1), ("p90", 2)] {
            let value = |r: &RealismReport| {
                let p = f(r);
                [p.p10, p.p50, p.p90][pick]
            };
            rows.push(ComparisonRow {
                statistic: format!("{name}, per frame {q}"),
                a: value(a),
                b: value(b),
            });
        }
    }
    rows
}

impl RealismComparison {
    /// The single figures: frames, points, background shape.
    pub fn rows(&self) -> Vec<ComparisonRow> {
        let (a, b) = (&self.a, &self.b);
        let row = |statistic: &str, f: fn(&RealismReport) -> f64| ComparisonRow {
            statistic: statistic.to_string(),
            a: f(a),
            b: f(b),
        };
        let mut rows = vec![
            row("frames", |r| r.frames as f64),
            row("returns per frame", |r| r.points_per_frame),
            row("returns per frame in the camera view", |r| r.view_points_per_frame),
            row("background neighbourhoods measured", |r| r.surfaces.sampled as f64),
            row("background volumetric, %", |r| r.surfaces.volumetric_percent),
            row("background planar vertical, %", |r| r.surfaces.vertical_percent),
            row("background height above the local ground, median (m)", |r| {
                r.surfaces.background_height_p50
            }),
            row("off-road ground above the road, p90 (m)", |r| r.surfaces.off_road_p90),
            row("car-sized background clusters per frame", |r| r.clusters.per_frame),
            row("car-sized background clusters per frame at 20–50 m", |r| {
                r.clusters.per_frame_20_50
            }),
            row("their mean reflectance at 35–50 m", |r| {
                r.clusters.mean_reflectance_35_50
            }),
            row("road rise 20 m ahead, per frame p10 (m)", |r| r.ground.rise_20m.p10),
            row("road rise 20 m ahead, per frame p50 (m)", |r| r.ground.rise_20m.p50),
            row("road rise 20 m ahead, per frame p90 (m)", |r| r.ground.rise_20m.p90),
            row("road rise 40 m ahead, per frame p10 (m)", |r| r.ground.rise_40m.p10),
            row("road rise 40 m ahead, per frame p50 (m)", |r| r.ground.rise_40m.p50),
            row("road rise 40 m ahead, per frame p90 (m)", |r| r.ground.rise_40m.p90),
            row("road in the flat center pool, per frame p10 (%)", |r| {
                r.ground.pool_road_percent.p10
            }),
            row("road in the flat center pool, per frame p50 (%)", |r| {
                r.ground.pool_road_percent.p50
            }),
            row("road in the flat center pool, per frame p90 (%)", |r| {
                r.ground.pool_road_percent.p90
            }),
        ];
        rows.extend(spread_rows(a, b));
        rows
    }

    fn reflectance_table(
        &self,
        f: &mut fmt::Formatter<'_>,
        title: &str,
        value: fn(&ReflectanceBin) -> f64,
        digits: usize,
    ) -> fmt::Result {
        writeln!(f, "\n{title} by range, A / B:\n")?;
        let heads: Vec<String> = RANGE_EDGES_M
            .windows(2)
            .map(|w| format!("{}–{} m", w[0], w[1]))
            .collect();
        writeln!(f, "| returns | {} |", heads.join(" | "))?;
        writeln!(f, "|---|{}", "---|".repeat(heads.len()))?;
        let (a, b) = (&self.a.reflectance, &self.b.reflectance);
        for (name, xa, xb) in [
            ("all", &a.all, &b.all),
            ("ground", &a.ground, &b.ground),
            ("cars", &a.cars, &b.cars),
            ("background", &a.background, &b.background),
        ] {
            let cells: Vec<String> = xa
                .iter()
                .zip(xb)
                .map(|(p, q)| match (p.points, q.points) {
                    (0, 0) => "-".to_string(),
                    _ => pair(value(p), value(q), digits),
                })
                .collect();
            writeln!(f, "| {name} | {} |", cells.join(" | "))?;
        }
        Ok(())
    }

    fn car_table(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "\nLabelled cars by distance, A / B:\n")?;
        writeln!(
            f,
            "| distance | cars | median returns | reflectance | zero % | above 1.1 m % | end-on % | three-quarter % | side % |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|---|---|")?;
        for (p, q) in self.a.cars.iter().zip(&self.b.cars) {
            // A bin without cars has no figures: "-" on its side.
            let side = |c: &CarBin, v: fn(&CarBin) -> f64, d: usize| {
                if c.cars == 0 {
                    "-".to_string()
                } else {
                    format!("{:.d$}", v(c))
                }
            };
            let cell = |v: fn(&CarBin) -> f64, d: usize| format!("{} / {}", side(p, v, d), side(q, v, d));
            writeln!(
                f,
                "| {}–{} m | {} | {} | {} | {} | {} | {} | {} | {} |",
                p.lo,
                p.hi,
                pair(p.cars as f64, q.cars as f64, 0),
                cell(|c| c.median_points, 0),
                cell(|c| c.mean_reflectance, 3),
                cell(|c| c.zero_percent, 0),
                cell(|c| c.high_percent, 0),
                cell(|c| c.end_on_percent, 0),
                cell(|c| c.three_quarter_percent, 0),
                cell(|c| c.side_percent, 0),
            )?;
        }
        self.fit_table(f)
    }

    fn fit_table(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "\nHow labelled car boxes sit on their returns (cars with at least {FIT_MIN_POINTS} returns), medians in metres, A / B:\n"
        )?;
        writeln!(
            f,
            "| distance | cars measured | box top above the returns | box end past the returns (the sensor's end) | depth of the end's returns behind it | road beside the car above the box bottom |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|")?;
        for (p, q) in self.a.cars.iter().zip(&self.b.cars) {
            let side = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
            let cell = |v: fn(&CarBin) -> Option<f64>| format!("{} / {}", side(v(p)), side(v(q)));
            writeln!(
                f,
                "| {}–{} m | {} | {} | {} | {} | {} |",
                p.lo,
                p.hi,
                pair(p.fitted as f64, q.fitted as f64, 0),
                cell(|c| c.top_gap_m),
                cell(|c| c.end_gap_m),
                cell(|c| c.end_depth_m),
                cell(|c| c.road_gap_m),
            )?;
        }
        self.end_tilt_table(f)
    }

    fn end_tilt_table(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "\nThe line through a car's end's returns (within {END_ZONE_M} m of the box's end, within its width), turned towards facing the sensor, median degrees, A / B:\n"
        )?;
        writeln!(f, "| seen from end-on | cars measured | the end's tilt |")?;
        writeln!(f, "|---|---|---|")?;
        for (p, q) in self.a.views.iter().zip(&self.b.views) {
            let side = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:+.1}"));
            writeln!(
                f,
                "| {}–{}° | {} | {} / {} |",
                p.lo,
                p.hi,
                pair(p.cars as f64, q.cars as f64, 0),
                side(p.end_tilt_deg),
                side(q.end_tilt_deg),
            )?;
        }
        Ok(())
    }
}

/// Markdown: the single figures, reflectance mean and zero share by range, cars by distance,
/// how their boxes sit on their returns, and how their ends' returns turn by view angle.
impl fmt::Display for RealismComparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "A = {}\nB = {}\n", self.a.root.display(), self.b.root.display())?;
        writeln!(f, "| statistic | A | B |")?;
        writeln!(f, "|---|---|---|")?;
        for r in self.rows() {
            let digits = if r.a.abs().max(r.b.abs()) >= 100.0 { 0 } else { 2 };
            writeln!(f, "| {} | {:.digits$} | {:.digits$} |", r.statistic, r.a, r.b)?;
        }
        self.reflectance_table(f, "Mean reflectance", |b| b.mean, 3)?;
        self.reflectance_table(f, "Returns reading exactly 0, %", |b| b.zero_percent, 0)?;
        self.car_table(f)
    }
}
