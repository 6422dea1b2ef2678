//! Units: helpers that keep km/h and m/s apart.

use serde::{Deserialize, Serialize};

/// Converts km/h to m/s.
pub fn kmh_to_mps(kmh: f64) -> f64 {
    kmh / 3.6
}

/// Converts m/s to km/h.
pub fn mps_to_kmh(mps: f64) -> f64 {
    mps * 3.6
}

/// A speed, stored in metres per second.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
pub struct Speed {
    mps: f64,
}

impl Speed {
    /// A speed given in km/h.
    pub fn kmh(kmh: f64) -> Speed {
        Speed {
            mps: kmh_to_mps(kmh),
        }
    }

    /// A speed given in m/s.
    pub fn mps(mps: f64) -> Speed {
        Speed { mps }
    }

    /// The speed in m/s.
    pub fn as_mps(self) -> f64 {
        self.mps
    }

    /// The speed in km/h.
    pub fn as_kmh(self) -> f64 {
        mps_to_kmh(self.mps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        assert!((Speed::kmh(100.0).as_mps() - 27.777_777).abs() < 1e-5);
        assert!((Speed::mps(10.0).as_kmh() - 36.0).abs() < 1e-12);
    }
}
