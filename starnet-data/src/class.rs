//! The object classes, by KITTI's names: the label files of every layout (KITTI's `label_2`, the
//! simulator's `label_360`, the custom layout's `labels/`) and the configs name them so.

use serde::{Deserialize, Serialize};

/// The KITTI object classes (`lingvo` rejects any other type; so do we).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum ObjectClass {
    Car,
    Van,
    Truck,
    Pedestrian,
    #[serde(rename = "Person_sitting")]
    PersonSitting,
    Cyclist,
    Tram,
    Misc,
    DontCare,
}

impl ObjectClass {
    /// Every class, in KITTI's order.
    pub const ALL: [ObjectClass; 9] = [
        Self::Car,
        Self::Van,
        Self::Truck,
        Self::Pedestrian,
        Self::PersonSitting,
        Self::Cyclist,
        Self::Tram,
        Self::Misc,
        Self::DontCare,
    ];

    /// The name as written in label files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Car => "Car",
            Self::Van => "Van",
            Self::Truck => "Truck",
            Self::Pedestrian => "Pedestrian",
            Self::PersonSitting => "Person_sitting",
            Self::Cyclist => "Cyclist",
            Self::Tram => "Tram",
            Self::Misc => "Misc",
            Self::DontCare => "DontCare",
        }
    }

    /// The class the KITTI devkit treats as this one's neighbour (Van for Car, Person_sitting
    /// for Pedestrian): its objects are neither found nor missed when this class is scored.
    pub fn neighbour(self) -> Option<Self> {
        match self {
            Self::Car => Some(Self::Van),
            Self::Pedestrian => Some(Self::PersonSitting),
            _ => None,
        }
    }

    /// Parses a label-file name; `None` for anything KITTI does not define.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.as_str() == name)
    }
}

impl std::fmt::Display for ObjectClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
