//! Range and sign rules of settings that no type can express, checked where each setting's
//! type lives: every config struct with such a rule has a `validate()` returning
//! [`InvalidSetting`], whose key is the field's path inside that struct. A caller that nests
//! the struct (the experiment file's `[augment]` table, say) prefixes it with
//! [`InvalidSetting::within`], so the error names the key as the user wrote it.

/// A setting outside its allowed range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct InvalidSetting {
    /// Dotted path of the setting, e.g. `gather.radius`.
    pub key: String,
    /// What is wrong and what is allowed.
    pub message: String,
}

impl InvalidSetting {
    /// An error for `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }

    /// The same error with `section.` put before its key.
    pub fn within(self, section: &str) -> Self {
        Self {
            key: format!("{section}.{}", self.key),
            ..self
        }
    }
}

/// Shorthand for a validation result.
pub type Checked = std::result::Result<(), InvalidSetting>;

/// `v` is finite and > 0.
pub fn positive(key: &str, v: f64) -> Checked {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(InvalidSetting::new(key, format!("{v} is not a positive number")))
    }
}

/// `v` is finite and ≥ 0.
pub fn non_negative(key: &str, v: f64) -> Checked {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(InvalidSetting::new(key, format!("{v} is not a finite number ≥ 0")))
    }
}

/// `v` is finite (any sign).
pub fn finite(key: &str, v: f64) -> Checked {
    if v.is_finite() {
        Ok(())
    } else {
        Err(InvalidSetting::new(key, format!("{v} is not a finite number")))
    }
}

/// `v` lies in `[lo, hi]`.
pub fn within(key: &str, v: f64, lo: f64, hi: f64) -> Checked {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(InvalidSetting::new(key, format!("{v} is not in [{lo}, {hi}]")))
    }
}

/// `n` ≥ 1.
pub fn at_least_one(key: &str, n: usize) -> Checked {
    if n >= 1 {
        Ok(())
    } else {
        Err(InvalidSetting::new(key, "must be at least 1"))
    }
}

/// The widest layer a setting may ask for: StarNet's widest is 384, and a width far beyond
/// any CPU's memory (a typo, a corrupt file) should be an error, not an allocation failure.
pub const MAX_WIDTH: usize = 4096;

/// A layer width: 1 ≤ `n` ≤ [`MAX_WIDTH`].
pub fn width(key: &str, n: usize) -> Checked {
    if (1..=MAX_WIDTH).contains(&n) {
        Ok(())
    } else {
        Err(InvalidSetting::new(
            key,
            format!("{n} is not a width in [1, {MAX_WIDTH}]"),
        ))
    }
}

/// `[min, max]` with min ≤ max, neither NaN (either may be infinite: an open side).
pub fn ordered_range(key: &str, r: [f32; 2]) -> Checked {
    if r[0] <= r[1] {
        Ok(())
    } else {
        Err(InvalidSetting::new(
            key,
            format!("[{}, {}] is not a range [min, max] with min ≤ max", r[0], r[1]),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_accept_their_bounds_and_reject_the_rest() {
        assert!(positive("k", 1e-9).is_ok());
        for v in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(positive("k", v).unwrap_err().key, "k");
        }
        assert!(non_negative("k", 0.0).is_ok());
        assert!(non_negative("k", -1e-9).is_err() && non_negative("k", f64::NAN).is_err());
        assert!(finite("k", -3.0).is_ok() && finite("k", f64::INFINITY).is_err() && finite("k", f64::NAN).is_err());
        assert!(within("k", 0.0, 0.0, 1.0).is_ok() && within("k", 1.0, 0.0, 1.0).is_ok());
        assert!(within("k", 1.01, 0.0, 1.0).is_err() && within("k", f64::NAN, 0.0, 1.0).is_err());
        assert!(at_least_one("k", 1).is_ok() && at_least_one("k", 0).is_err());
        assert!(ordered_range("k", [0.0, f32::INFINITY]).is_ok() && ordered_range("k", [1.0, 1.0]).is_ok());
        assert!(ordered_range("k", [1.0, 0.0]).is_err() && ordered_range("k", [f32::NAN, 0.0]).is_err());
        let e = at_least_one("radius", 0)
            .unwrap_err()
            .within("gather")
            .within("pipeline");
        assert_eq!(e.key, "pipeline.gather.radius");
        assert_eq!(e.to_string(), "pipeline.gather.radius: must be at least 1");
    }
}
