//! The one typeface of every picture: DejaVu Sans (Bitstream Vera licence,
//! `assets/DejaVuSans-LICENSE.txt`), compiled in, so no system font is looked up.

use plotters::style::{FontFamily, FontStyle, register_font};
use std::sync::Once;

/// The family every renderer names.
pub const FAMILY: FontFamily<'static> = FontFamily::SansSerif;

static TTF: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Registers the shipped TTF with `plotters` (once per process).
pub fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TTF, checked by the test below; a failure here would leave
        // text to fail with plotters' "font unavailable", naming the cause.
        let _ = register_font(FAMILY.as_str(), FontStyle::Normal, TTF);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_font_parses() {
        assert!(register_font("starnet-test", FontStyle::Normal, TTF).is_ok());
    }
}
