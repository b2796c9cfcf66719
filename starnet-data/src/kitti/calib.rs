//! `calib` files: `KEY: v v ...` lines with `%.12e` values, keys `P0 P1 P2 P3 R0_rect
//! Tr_velo_to_cam Tr_imu_to_velo` in that order, and one extra `\n` after the last line.
//! P2, R0_rect and Tr_velo_to_cam are required; every other key is kept and written back. The
//! tracking benchmark's files (`R_rect`, `Tr_velo_cam`, `Tr_imu_velo`, lines without the colon)
//! read the same; written back, they take the object-detection names of the two required keys.

use crate::io::{atomic_write, parse_finite_numbers, read_text};
use crate::{DataError, Result};
use nalgebra::{Matrix3, Matrix3x4, Matrix4};
use std::path::Path;

/// The key order of real KITTI files (OpenPCDet reads lines 2–5 by index).
const CANONICAL: [&str; 7] = ["P0", "P1", "P2", "P3", "R0_rect", "Tr_velo_to_cam", "Tr_imu_to_velo"];

/// The calibration file of KITTI object training frame 000000 (recorded 2011-09-28), byte for
/// byte. The simulator projects through it, so its labels match a real KITTI camera.
pub const KITTI_000000_CALIB: &str = "P0: 7.070493000000e+02 0.000000000000e+00 6.040814000000e+02 0.000000000000e+00 0.000000000000e+00 7.070493000000e+02 1.805066000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00
P1: 7.070493000000e+02 0.000000000000e+00 6.040814000000e+02 -3.797842000000e+02 0.000000000000e+00 7.070493000000e+02 1.805066000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00
P2: 7.070493000000e+02 0.000000000000e+00 6.040814000000e+02 4.575831000000e+01 0.000000000000e+00 7.070493000000e+02 1.805066000000e+02 -3.454157000000e-01 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 4.981016000000e-03
P3: 7.070493000000e+02 0.000000000000e+00 6.040814000000e+02 -3.341081000000e+02 0.000000000000e+00 7.070493000000e+02 1.805066000000e+02 2.330660000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 3.201153000000e-03
R0_rect: 9.999128000000e-01 1.009263000000e-02 -8.511932000000e-03 -1.012729000000e-02 9.999406000000e-01 -4.037671000000e-03 8.470675000000e-03 4.123522000000e-03 9.999556000000e-01
Tr_velo_to_cam: 6.927964000000e-03 -9.999722000000e-01 -2.757829000000e-03 -2.457729000000e-02 -1.162982000000e-03 2.749836000000e-03 -9.999955000000e-01 -6.127237000000e-02 9.999753000000e-01 6.931141000000e-03 -1.143899000000e-03 -3.321029000000e-01
Tr_imu_to_velo: 9.999976000000e-01 7.553071000000e-04 -2.035826000000e-03 -8.086759000000e-01 -7.854027000000e-04 9.998898000000e-01 -1.482298000000e-02 3.195559000000e-01 2.024406000000e-03 1.482454000000e-02 9.998881000000e-01 -7.997231000000e-01

";

/// Camera calibration of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Calib {
    p2: Matrix3x4<f64>,
    r0_rect: Matrix3<f64>,
    tr_velo_to_cam: Matrix3x4<f64>,
    /// Every other key with its values, in file order (P0, P1, P3, Tr_imu_to_velo, extras).
    others: Vec<(String, Vec<f64>)>,
    /// `R0_rect · Tr_velo_to_cam` as 4 × 4: LiDAR → camera-rect.
    lidar_to_rect: Matrix4<f64>,
    /// Its inverse.
    rect_to_lidar: Matrix4<f64>,
}

impl Calib {
    /// Builds a calibration from the three matrices every conversion needs, plus any other
    /// keys to keep (e.g. `P0`, `Tr_imu_to_velo`).
    pub fn new(
        p2: Matrix3x4<f64>,
        r0_rect: Matrix3<f64>,
        tr_velo_to_cam: Matrix3x4<f64>,
        others: Vec<(String, Vec<f64>)>,
    ) -> Self {
        let lidar_to_rect = pad4(&r0_rect.insert_column(3, 0.0)) * pad4(&tr_velo_to_cam);
        let rect_to_lidar = lidar_to_rect.try_inverse().unwrap_or_else(Matrix4::identity);
        Self {
            p2,
            r0_rect,
            tr_velo_to_cam,
            others,
            lidar_to_rect,
            rect_to_lidar,
        }
    }

    /// Projection matrix of the left colour camera (image 2).
    pub fn p2(&self) -> &Matrix3x4<f64> {
        &self.p2
    }

    /// Rectifying rotation of camera 0.
    pub fn r0_rect(&self) -> &Matrix3<f64> {
        &self.r0_rect
    }

    /// LiDAR → unrectified camera 0.
    pub fn tr_velo_to_cam(&self) -> &Matrix3x4<f64> {
        &self.tr_velo_to_cam
    }

    /// LiDAR → camera-rect as a 4 × 4 homogeneous matrix.
    pub fn lidar_to_rect_matrix(&self) -> &Matrix4<f64> {
        &self.lidar_to_rect
    }

    /// Camera-rect → LiDAR as a 4 × 4 homogeneous matrix.
    pub fn rect_to_lidar_matrix(&self) -> &Matrix4<f64> {
        &self.rect_to_lidar
    }

    /// The values of any key, by name.
    pub fn get(&self, key: &str) -> Option<Vec<f64>> {
        match key {
            "P2" => Some(row_major(&self.p2)),
            "R0_rect" => Some(row_major(&self.r0_rect)),
            "Tr_velo_to_cam" => Some(row_major(&self.tr_velo_to_cam)),
            _ => self.others.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone()),
        }
    }

    /// Parses a calib file held in memory; `path` names it in errors. Lines may be
    /// `KEY: values` or `KEY values`; blank lines are skipped. `R_rect` and `Tr_velo_cam` (the
    /// tracking benchmark's names) stand for `R0_rect` and `Tr_velo_to_cam`.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let mut entries: Vec<(String, Vec<f64>, usize)> = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let (key, rest) = match line.split_once(':') {
                Some((k, r)) => (k.trim(), r),
                None => line.trim().split_once(' ').unwrap_or((line.trim(), "")),
            };
            let values = parse_finite_numbers(rest, path, i + 1, key)?;
            if entries.iter().any(|(k, ..)| k == key) {
                return Err(DataError::parse(path, i + 1, key, "key appears twice"));
            }
            entries.push((key.to_string(), values, i + 1));
        }
        // Each required key under its object-detection name, or the tracking benchmark's.
        let mut take = |keys: &[&'static str], n: usize| -> Result<Vec<f64>> {
            let pos = entries.iter().position(|(k, ..)| keys.contains(&k.as_str()));
            let missing = DataError::MissingCalibKey {
                path: path.into(),
                key: keys[0],
            };
            let (key, v, line) = entries.remove(pos.ok_or(missing)?);
            if v.len() != n {
                return Err(DataError::parse(
                    path,
                    line,
                    key,
                    format!("expected {n} values, found {}", v.len()),
                ));
            }
            Ok(v)
        };
        let p2 = Matrix3x4::from_row_slice(&take(&["P2"], 12)?);
        let r0 = Matrix3::from_row_slice(&take(&["R0_rect", "R_rect"], 9)?);
        let tr = Matrix3x4::from_row_slice(&take(&["Tr_velo_to_cam", "Tr_velo_cam"], 12)?);
        let others = entries.into_iter().map(|(k, v, _)| (k, v)).collect();
        Ok(Self::new(p2, r0, tr, others))
    }

    /// The file text exactly as KITTI writes it: canonical keys in canonical order, then any
    /// other keys in their original order, values as C's `%.12e`, and a final empty line.
    pub fn format(&self) -> String {
        let mut keys: Vec<&str> = CANONICAL.iter().copied().filter(|k| self.get(k).is_some()).collect();
        keys.extend(
            self.others
                .iter()
                .map(|(k, _)| k.as_str())
                .filter(|k| !CANONICAL.contains(k)),
        );
        let mut out = String::with_capacity(1700);
        for key in keys {
            let values = self.get(key).unwrap_or_default();
            let text: Vec<String> = values.iter().map(|v| format_c_exp(*v, 12)).collect();
            out.push_str(&format!("{key}: {}\n", text.join(" ")));
        }
        out.push('\n');
        out
    }

    /// The calibration of KITTI training frame 000000 ([`KITTI_000000_CALIB`]).
    pub fn kitti_000000() -> Self {
        Self::parse(KITTI_000000_CALIB, Path::new("KITTI_000000_CALIB")).expect("the embedded calibration parses")
    }

    /// Reads a calib file.
    pub fn read(path: &Path) -> Result<Self> {
        Self::parse(&read_text(path)?, path)
    }

    /// Writes a calib file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        atomic_write(path, self.format().as_bytes())
    }
}

fn pad4(m: &Matrix3x4<f64>) -> Matrix4<f64> {
    m.insert_row(3, 0.0)
        .map_with_location(|r, c, v| if r == 3 && c == 3 { 1.0 } else { v })
}

fn row_major<R: nalgebra::Dim, C: nalgebra::Dim, S: nalgebra::RawStorage<f64, R, C>>(
    m: &nalgebra::Matrix<f64, R, C, S>,
) -> Vec<f64> {
    m.row_iter()
        .flat_map(|r| r.iter().copied().collect::<Vec<_>>())
        .collect()
}

/// C's `%.{prec}e`: mantissa with `prec` decimals, `e`, a sign and at least two exponent
/// digits (`7.070493000000e+02`). Rust's `{:e}` writes `7.070493000000e2`.
pub fn format_c_exp(v: f64, prec: usize) -> String {
    let s = format!("{v:.prec$e}");
    let (mantissa, exp) = s.split_once('e').expect("`{:e}` always has an exponent");
    let exp: i32 = exp.parse().expect("integer exponent");
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}e{sign}{:02}", exp.abs())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) const SAMPLE: &str = super::KITTI_000000_CALIB;

    #[test]
    fn c_exponent_format() {
        assert_eq!(format_c_exp(707.0493, 12), "7.070493000000e+02");
        assert_eq!(format_c_exp(-0.3454157, 12), "-3.454157000000e-01");
        assert_eq!(format_c_exp(0.0, 12), "0.000000000000e+00");
        assert_eq!(format_c_exp(1.5e-120, 3), "1.500e-120");
    }

    #[test]
    fn sample_round_trips_byte_for_byte() {
        let c = Calib::parse(SAMPLE, Path::new("calib.txt")).unwrap();
        assert_eq!(c.p2()[(0, 3)], 45.75831);
        assert_eq!(c.r0_rect()[(1, 0)], -1.012729e-2);
        assert_eq!(c.format(), SAMPLE);
    }

    #[test]
    fn tracking_files_read_as_object_detection_ones() {
        // The tracking devkit's layout: the rectification and LiDAR keys renamed, without colons.
        let tracking = SAMPLE
            .replace("R0_rect:", "R_rect")
            .replace("Tr_velo_to_cam:", "Tr_velo_cam")
            .replace("Tr_imu_to_velo:", "Tr_imu_velo");
        let c = Calib::parse(&tracking, Path::new("calib/0000.txt")).unwrap();
        let object = Calib::parse(SAMPLE, Path::new("calib.txt")).unwrap();
        assert_eq!(c.r0_rect(), object.r0_rect());
        assert_eq!(c.lidar_to_rect_matrix(), object.lidar_to_rect_matrix());
        assert_eq!(c.p2(), object.p2());
        // Written back with the object-detection names of the required keys; the IMU line is kept.
        let written = c.format();
        assert!(
            written.contains("\nR0_rect: ") && written.contains("\nTr_velo_to_cam: "),
            "{written}"
        );
        assert!(written.contains("\nTr_imu_velo: "), "{written}");
        let err = Calib::parse(&tracking.replace("R_rect", "R_wrong"), Path::new("calib/0000.txt")).unwrap_err();
        assert!(
            matches!(err, DataError::MissingCalibKey { key: "R0_rect", .. }),
            "{err:?}"
        );
    }

    #[test]
    fn missing_required_key_is_named() {
        let text: String = SAMPLE
            .lines()
            .filter(|l| !l.starts_with("Tr_velo_to_cam"))
            .map(|l| format!("{l}\n"))
            .collect();
        let err = Calib::parse(&text, Path::new("calib/000004.txt")).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::MissingCalibKey {
                    key: "Tr_velo_to_cam",
                    ..
                }
            ),
            "{err:?}"
        );
        assert_eq!(
            err.to_string(),
            "calib/000004.txt: missing required calibration key `Tr_velo_to_cam`"
        );
    }

    #[test]
    fn unknown_keys_are_kept_and_written_last() {
        let text = SAMPLE.replacen("P3:", "Extra: 1.000000000000e+00\nP3:", 1);
        let c = Calib::parse(&text, Path::new("c.txt")).unwrap();
        assert_eq!(c.get("Extra"), Some(vec![1.0]));
        let out = c.format();
        assert!(out.ends_with("Extra: 1.000000000000e+00\n\n"), "{out}");
    }

    #[test]
    fn wrong_value_count_and_bad_number() {
        let short = SAMPLE.replace(" 4.981016000000e-03\n", "\n");
        let err = Calib::parse(&short, Path::new("c.txt")).unwrap_err();
        assert!(
            err.to_string().starts_with("c.txt:3: P2: expected 12 values, found 11"),
            "{err}"
        );
        let bad = SAMPLE.replace("9.999406000000e-01", "x");
        let err = Calib::parse(&bad, Path::new("c.txt")).unwrap_err();
        assert!(err.to_string().starts_with("c.txt:5: R0_rect: value 5 `x`"), "{err}");
    }

    #[test]
    fn rect_to_lidar_inverts_lidar_to_rect() {
        let c = Calib::parse(SAMPLE, Path::new("c.txt")).unwrap();
        let id = c.rect_to_lidar_matrix() * c.lidar_to_rect_matrix();
        assert!((id - Matrix4::identity()).abs().max() < 1e-12);
    }
}
