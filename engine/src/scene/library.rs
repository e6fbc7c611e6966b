//! The built-in material library: surfaces common in rooms and halls, so a
//! scene can say `"concrete"` instead of spelling out 24 coefficients.
//!
//! Sources. Absorption, 125 Hz – 4 kHz: M. Vorländer, *Auralization* (Springer
//! 2008), Appendix A (absorption coefficients of common materials), which in
//! turn collects the classic tables also found in H. Kuttruff, *Room
//! Acoustics* (5th ed. 2009), Table 6.2, and L. Beranek, *Concert Halls and
//! Opera Houses* (2004) for audience and seats. Scattering: Vorländer (2008)
//! Appendix A scattering tables and T. Cox & P. D'Antonio, *Acoustic Absorbers
//! and Diffusers* (2nd ed. 2009), ch. 10–11; these are typical estimates, as
//! scattering of a real surface depends on its relief. Transmission: from a
//! sound reduction index R as τ = 10^(−R/10) (mass-law values, Kuttruff ch.
//! 10; Vorländer ch. 12).
//!
//! The tables start at 125 Hz and most end at 4 kHz. Extrapolation:
//! - 63 Hz: rigid and massive surfaces (concrete, brick, plaster, marble,
//!   glass, water) keep their 125 Hz value, since their absorption is
//!   nearly flat at low frequency; porous absorbers (carpet, curtain, tile,
//!   seats, audience) take about 60 % of the 125 Hz value, following the
//!   roughly 6 dB/octave fall of porous absorption below its lowest tabulated
//!   band; panel resonators (wood panel, door) keep the 125 Hz value, as
//!   their resonance usually lies between 63 and 125 Hz.
//! - 8 kHz: where a table stops at 4 kHz, the 4 kHz value is repeated
//!   (air absorption, not surfaces, dominates there).

use super::{Bands, Material, BAND_COUNT};

/// One library row, kept as plain arrays so the table reads like the sources.
struct Entry {
    name: &'static str,
    absorption: Bands,
    scattering: Bands,
    transmission: Bands,
}

const NONE: Bands = [0.0; BAND_COUNT];

// Columns: 63, 125, 250, 500, 1k, 2k, 4k, 8k Hz.
const TABLE: &[Entry] = &[
    // Vorländer A: "smooth unpainted concrete".
    Entry {
        name: "concrete",
        absorption: [0.01, 0.01, 0.01, 0.02, 0.02, 0.02, 0.05, 0.05],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.1, 0.1, 0.15, 0.15],
        transmission: NONE,
    },
    // Vorländer A: "smooth concrete, painted".
    Entry {
        name: "painted_concrete",
        absorption: [0.01, 0.01, 0.01, 0.01, 0.02, 0.02, 0.02, 0.02],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.1, 0.1, 0.1],
        transmission: NONE,
    },
    // Vorländer A: "unglazed brickwork"; joints scatter a little at HF.
    Entry {
        name: "brick",
        absorption: [0.03, 0.03, 0.03, 0.03, 0.04, 0.05, 0.07, 0.07],
        scattering: [0.05, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.3],
        transmission: NONE,
    },
    // Vorländer A / Kuttruff 6.2: "plaster, smooth, on brick".
    Entry {
        name: "plaster",
        absorption: [0.013, 0.013, 0.015, 0.02, 0.03, 0.04, 0.05, 0.05],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.1, 0.1, 0.1],
        transmission: NONE,
    },
    // Kuttruff 6.2: "plywood panelling, 1 cm, on battens" (panel resonator).
    Entry {
        name: "wood_panel",
        absorption: [0.28, 0.28, 0.22, 0.17, 0.09, 0.1, 0.11, 0.11],
        scattering: [0.05, 0.05, 0.05, 0.1, 0.1, 0.15, 0.2, 0.2],
        transmission: NONE,
    },
    // Vorländer A: "ordinary window glass"; R ≈ 20–35 dB (4 mm pane).
    Entry {
        name: "glass_window",
        absorption: [0.35, 0.35, 0.25, 0.18, 0.12, 0.07, 0.04, 0.04],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05],
        transmission: [0.02, 0.01, 0.005, 0.002, 0.001, 0.0005, 0.0003, 0.0003],
    },
    // Vorländer A: "heavy carpet on concrete".
    Entry {
        name: "carpet_on_concrete",
        absorption: [0.01, 0.02, 0.06, 0.14, 0.37, 0.6, 0.65, 0.65],
        scattering: [0.1, 0.1, 0.1, 0.15, 0.2, 0.25, 0.3, 0.3],
        transmission: NONE,
    },
    // Kuttruff 6.2: "heavy velour curtain, draped to half area".
    Entry {
        name: "heavy_curtain",
        absorption: [0.08, 0.14, 0.35, 0.55, 0.72, 0.7, 0.65, 0.65],
        scattering: [0.1, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5, 0.5],
        transmission: NONE,
    },
    // Vorländer A: "mineral fibre ceiling tile, suspended".
    Entry {
        name: "acoustic_tile",
        absorption: [0.42, 0.7, 0.66, 0.72, 0.92, 0.88, 0.75, 0.75],
        scattering: [0.1, 0.1, 0.1, 0.1, 0.15, 0.2, 0.2, 0.2],
        transmission: NONE,
    },
    // Beranek (2004) / Vorländer A: "upholstered seats, unoccupied".
    Entry {
        name: "upholstered_seats",
        absorption: [0.3, 0.49, 0.66, 0.8, 0.88, 0.82, 0.7, 0.7],
        scattering: [0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.7, 0.7],
        transmission: NONE,
    },
    // Beranek (2004) / Vorländer A: "audience on upholstered seats".
    Entry {
        name: "audience",
        absorption: [0.36, 0.6, 0.74, 0.88, 0.96, 0.93, 0.85, 0.85],
        scattering: [0.3, 0.3, 0.5, 0.6, 0.6, 0.7, 0.7, 0.7],
        transmission: NONE,
    },
    // Vorländer A: "marble or glazed tile".
    Entry {
        name: "marble",
        absorption: [0.01, 0.01, 0.01, 0.01, 0.01, 0.02, 0.02, 0.02],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05],
        transmission: NONE,
    },
    // Kuttruff 6.2: "water surface (pool)".
    Entry {
        name: "water",
        absorption: [0.008, 0.008, 0.008, 0.013, 0.015, 0.02, 0.025, 0.025],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05],
        transmission: NONE,
    },
    // Kuttruff 6.2: "solid wood door"; R = 15..40 dB rising with frequency
    // (light door or thin partition, mass law with leaks).
    Entry {
        name: "thin_partition",
        absorption: [0.14, 0.14, 0.1, 0.06, 0.08, 0.1, 0.1, 0.1],
        scattering: [0.05, 0.05, 0.05, 0.05, 0.05, 0.1, 0.1, 0.1],
        transmission: [
            0.0316, 0.01, 0.0032, 0.001, 0.000_32, 0.000_16, 0.0001, 0.0001,
        ],
    },
    // Idealised reflector for tests and comparisons with image sources.
    Entry {
        name: "rigid",
        absorption: [0.01; BAND_COUNT],
        scattering: NONE,
        transmission: NONE,
    },
    // Idealised absorber (free-field conditions).
    Entry {
        name: "anechoic",
        absorption: [0.99; BAND_COUNT],
        scattering: NONE,
        transmission: NONE,
    },
];

fn to_material(e: &Entry) -> Material {
    Material {
        name: e.name.to_owned(),
        absorption: e.absorption,
        scattering: e.scattering,
        transmission: e.transmission,
    }
}

/// Every material of the library, in table order.
pub fn builtin_materials() -> Vec<Material> {
    TABLE.iter().map(to_material).collect()
}

/// The library material called `name`, if there is one.
pub fn builtin_material(name: &str) -> Option<Material> {
    TABLE.iter().find(|e| e.name == name).map(to_material)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_material_is_valid_and_unique() {
        let all = builtin_materials();
        assert!((12..=16).contains(&all.len()));
        for (i, m) in all.iter().enumerate() {
            m.clone().validated().unwrap();
            assert!(all[..i].iter().all(|o| o.name != m.name), "{}", m.name);
        }
    }

    #[test]
    fn lookup_by_name() {
        assert!(builtin_material("concrete").is_some());
        assert!(builtin_material("Concrete").is_none());
        assert!(builtin_material("thin_partition").unwrap().transmits());
        assert_eq!(builtin_material("anechoic").unwrap().absorption[0], 0.99);
    }
}
