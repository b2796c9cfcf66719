//! `starnet synth --stats`: the statistics of a generated set beside KITTI's
//! (`kitti-format.md` §2 and §4), so a user can see how far the simulator is from real data.

use starnet_data::Result;
use starnet_data::kitti::read_sidecar;
use starnet_data::kitti::{Difficulty, KittiDataset, ObjectClass};
use std::f32::consts::PI;
use std::fmt;

/// One row of the table: a figure, its value on the generated set, and KITTI's.
#[derive(Debug, Clone, PartialEq)]
pub struct StatRow {
    /// What is measured.
    pub name: String,
    /// Value on the generated set.
    pub generated: f64,
    /// KITTI's value, where the reference has one.
    pub kitti: Option<f64>,
}

impl StatRow {
    /// generated / KITTI.
    pub fn ratio(&self) -> Option<f64> {
        self.kitti.filter(|k| *k != 0.0).map(|k| self.generated / k)
    }
}

/// The statistics table of a generated set.
#[derive(Debug, Clone, Default)]
pub struct DatasetStats {
    /// Frames read.
    pub frames: usize,
    /// The rows, in print order.
    pub rows: Vec<StatRow>,
}

fn quantile(v: &[f64], q: f64) -> f64 {
    starnet_data::summary::quantile(v, q).unwrap_or(f64::NAN)
}

fn share(v: &[bool]) -> f64 {
    100.0 * v.iter().filter(|b| **b).count() as f64 / v.len().max(1) as f64
}

/// Pedestrians' and cyclists' sizes against KITTI's tracking labels, and their returns by distance
/// (the reference has no per-distance figure for them: the generated value stands alone).
fn small_object_rows(
    points: &std::collections::BTreeMap<ObjectClass, Vec<f64>>,
    dist: &std::collections::BTreeMap<ObjectClass, Vec<f64>>,
    sizes: &std::collections::BTreeMap<ObjectClass, Vec<[f64; 3]>>,
) -> Vec<StatRow> {
    let mut rows = Vec::new();
    for (class, kitti) in [
        (ObjectClass::Pedestrian, [0.90, 0.73, 1.76]),
        (ObjectClass::Cyclist, [1.75, 0.68, 1.74]),
    ] {
        let size = sizes.get(&class).map(Vec::as_slice).unwrap_or_default();
        for (i, axis) in ["length", "width", "height"].into_iter().enumerate() {
            let mean = size.iter().map(|s| s[i]).sum::<f64>() / size.len() as f64; // NaN without one
            rows.push(StatRow {
                name: format!("{class} {axis}, mean (m)"),
                generated: mean,
                kitti: Some(kitti[i]),
            });
        }
        let (p, d) = (points.get(&class), dist.get(&class));
        let pairs: Vec<(f64, f64)> = p
            .zip(d)
            .map(|(p, d)| d.iter().copied().zip(p.iter().copied()).collect())
            .unwrap_or_default();
        for lo in [0.0, 10.0, 20.0, 30.0] {
            let within: Vec<f64> = pairs
                .iter()
                .filter(|(d, _)| (lo..lo + 10.0).contains(d))
                .map(|(_, p)| *p)
                .collect();
            rows.push(StatRow {
                name: format!("{class} points per object at {lo}-{} m, median", lo + 10.0),
                generated: quantile(&within, 0.5),
                kitti: None,
            });
        }
    }
    rows
}

/// Reads every frame of `root/training` (labels, points, the 360° sidecar when present) and
/// computes the table.
pub fn dataset_stats(root: &std::path::Path) -> Result<DatasetStats> {
    let ds = KittiDataset::open(root, None)?;
    let mut s = DatasetStats {
        frames: ds.ids().len(),
        rows: Vec::new(),
    };
    let n = s.frames.max(1) as f64;
    let mut row = |name: &str, generated: f64, kitti: Option<f64>| {
        s.rows.push(StatRow {
            name: name.to_string(),
            generated,
            kitti,
        })
    };

    let (mut pts, mut fov_pts, mut per_class) = (Vec::new(), Vec::new(), std::collections::BTreeMap::new());
    let (mut has_car, mut has_ped, mut has_cyc) = (Vec::new(), Vec::new(), Vec::new());
    let mut obj_points: std::collections::BTreeMap<ObjectClass, Vec<f64>> = Default::default();
    let mut dist: std::collections::BTreeMap<ObjectClass, Vec<f64>> = Default::default();
    let mut sizes: std::collections::BTreeMap<ObjectClass, Vec<[f64; 3]>> = Default::default();
    let (mut car_aligned, mut ped_aligned, mut car_occ, mut car_diff) =
        (Vec::new(), Vec::new(), [0usize; 4], [0usize; 4]);
    let mut sidecar_objects = 0usize;
    for id in ds.ids() {
        let frame = ds.load(id)?;
        pts.push(frame.points.len() as f64);
        fov_pts.push(frame.calib.crop_to_fov(&frame.points, frame.image_size).len() as f64);
        let sidecar = ds.path("label_360", id, "txt");
        if sidecar.is_file() {
            sidecar_objects += read_sidecar(&sidecar)?.len();
        }
        for o in &frame.objects {
            *per_class.entry(o.class).or_insert(0usize) += 1;
        }
        let count = |c: ObjectClass| frame.objects.iter().any(|o| o.class == c);
        has_car.push(!count(ObjectClass::Car));
        has_ped.push(count(ObjectClass::Pedestrian));
        has_cyc.push(count(ObjectClass::Cyclist));
        for (o, b) in frame.labelled_boxes() {
            obj_points
                .entry(o.class)
                .or_default()
                .push(b.count_points_inside(&frame.points) as f64);
            dist.entry(o.class).or_default().push(o.cam.x.hypot(o.cam.z) as f64);
            sizes
                .entry(o.class)
                .or_default()
                .push([b.dx, b.dy, b.dz].map(f64::from));
            // Aligned with the road: within 20° of the ego's axis either way (ry ≈ ±π/2).
            let off = (b.heading.rem_euclid(PI)).min(PI - b.heading.rem_euclid(PI));
            match o.class {
                ObjectClass::Car => {
                    car_aligned.push(off < 20f32.to_radians());
                    car_occ[o.occluded.clamp(0, 3) as usize] += 1;
                    car_diff[match o.difficulty() {
                        Some(Difficulty::Easy) => 0,
                        Some(Difficulty::Moderate) => 1,
                        Some(Difficulty::Hard) => 2,
                        None => 3,
                    }] += 1;
                }
                ObjectClass::Pedestrian => ped_aligned.push(off < 20f32.to_radians()),
                _ => {}
            }
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let sd = |v: &[f64]| {
        let m = mean(v);
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    row("points per frame, mean", mean(&pts), Some(119_225.0));
    row("points per frame, sd", sd(&pts), Some(5_219.0));
    row("points in the camera view, mean", mean(&fov_pts), Some(18_968.0));
    use ObjectClass::*;
    for (class, kitti) in [
        (Car, 3.87),
        (Pedestrian, 0.59),
        (Cyclist, 0.20),
        (Van, 0.35),
        (Truck, 0.13),
        (Misc, 0.09),
        (PersonSitting, 0.015),
        (DontCare, 1.51),
    ] {
        row(
            &format!("{class} per frame"),
            *per_class.get(&class).unwrap_or(&0) as f64 / n,
            Some(kitti),
        );
    }
    row(
        "objects per frame over 360° (sidecar)",
        sidecar_objects as f64 / n,
        None,
    );
    row("% frames without a car", share(&has_car), Some(12.0));
    row("% frames with a pedestrian", share(&has_ped), Some(26.0));
    row("% frames with a cyclist", share(&has_cyc), Some(14.0));
    for (class, kitti) in [
        (Car, [253.0, 80.0, 8.0, 771.0]),
        (Pedestrian, [155.0, 89.0, 15.0, 375.0]),
        (Cyclist, [135.0, 75.0, 16.0, 355.0]),
    ] {
        let v = obj_points.entry(class).or_default();
        row(&format!("{class} points per object, mean"), mean(v), Some(kitti[0]));
        row(
            &format!("{class} points per object, median"),
            quantile(v, 0.5),
            Some(kitti[1]),
        );
        row(
            &format!("{class} points per object, p10"),
            quantile(v, 0.1),
            Some(kitti[2]),
        );
        row(
            &format!("{class} points per object, p90"),
            quantile(v, 0.9),
            Some(kitti[3]),
        );
    }
    for r in small_object_rows(&obj_points, &dist, &sizes) {
        row(&r.name, r.generated, r.kitti);
    }
    let cars = obj_points.entry(Car).or_default().clone();
    row(
        "% cars with 0 points",
        share(&cars.iter().map(|p| *p == 0.0).collect::<Vec<_>>()),
        Some(2.1),
    );
    row(
        "% cars with < 5 points",
        share(&cars.iter().map(|p| *p < 5.0).collect::<Vec<_>>()),
        Some(6.4),
    );
    let car_dist = dist.entry(Car).or_default().clone();
    row("car distance from camera, mean (m)", mean(&car_dist), Some(30.8));
    row("car distance, median (m)", quantile(&car_dist, 0.5), Some(28.6));
    for (i, kitti) in [10.0, 20.0, 24.0, 20.0, 13.0, 7.0, 4.5, 2.2].into_iter().enumerate() {
        let lo = 10.0 * i as f64;
        let share_bin = share(&car_dist.iter().map(|d| (lo..lo + 10.0).contains(d)).collect::<Vec<_>>());
        row(&format!("% cars at {}-{} m", lo, lo + 10.0), share_bin, Some(kitti));
    }
    row(
        "pedestrian distance, median (m)",
        quantile(dist.entry(Pedestrian).or_default(), 0.5),
        Some(13.6),
    );
    row(
        "cyclist distance, median (m)",
        quantile(dist.entry(Cyclist).or_default(), 0.5),
        Some(20.7),
    );
    row("% cars within 20° of the road axis", share(&car_aligned), Some(82.0));
    row(
        "% pedestrians within 20° of the road axis",
        share(&ped_aligned),
        Some(44.0),
    );
    let total_cars = car_occ.iter().sum::<usize>().max(1) as f64;
    for (level, kitti) in [50.0, 31.0, 18.0, 2.0].into_iter().enumerate() {
        row(
            &format!("% cars with occlusion {level}"),
            100.0 * car_occ[level] as f64 / total_cars,
            Some(kitti),
        );
    }
    for (i, name) in ["easy", "moderate only", "hard only", "no difficulty"]
        .into_iter()
        .enumerate()
    {
        row(&format!("% cars {name}"), 100.0 * car_diff[i] as f64 / total_cars, None);
    }
    Ok(s)
}

impl fmt::Display for DatasetStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} frames", self.frames)?;
        writeln!(f, "| figure | generated | KITTI | ratio |")?;
        writeln!(f, "|---|---|---|---|")?;
        for r in &self.rows {
            let fmt_v = |v: f64| {
                if v.abs() >= 100.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v:.2}")
                }
            };
            let kitti = r.kitti.map_or("-".to_string(), fmt_v);
            let ratio = r.ratio().map_or("-".to_string(), |x| format!("{x:.2}"));
            writeln!(f, "| {} | {} | {kitti} | {ratio} |", r.name, fmt_v(r.generated))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn small_object_rows_average_sizes_and_bin_returns_by_distance() {
        let ped = ObjectClass::Pedestrian;
        let points = BTreeMap::from([(ped, vec![100.0, 40.0, 60.0])]);
        let dist = BTreeMap::from([(ped, vec![5.0, 15.0, 16.0])]);
        let sizes = BTreeMap::from([(ped, vec![[0.8, 0.7, 1.7], [1.0, 0.5, 1.9], [0.9, 0.6, 1.8]])]);
        let rows = small_object_rows(&points, &dist, &sizes);
        let get = |name: &str| rows.iter().find(|r| r.name == name).unwrap_or_else(|| panic!("{name}"));
        assert!((get("Pedestrian length, mean (m)").generated - 0.9).abs() < 1e-9);
        assert_eq!(get("Pedestrian height, mean (m)").kitti, Some(1.76));
        assert_eq!(get("Pedestrian points per object at 0-10 m, median").generated, 100.0);
        // The nearest-rank median of 40 and 60.
        assert_eq!(get("Pedestrian points per object at 10-20 m, median").generated, 60.0);
        assert!(
            get("Pedestrian points per object at 20-30 m, median")
                .generated
                .is_nan()
        );
        // No cyclist: its rows are there, with no value.
        assert!(get("Cyclist width, mean (m)").generated.is_nan());
    }
}
