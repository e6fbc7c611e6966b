use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Number of octave bands the engine tracks.
pub const BAND_COUNT: usize = 8;

/// Centre frequencies of the octave bands, 63 Hz to 8 kHz (ISO 266).
pub const OCTAVE_BANDS_HZ: [f32; BAND_COUNT] =
    [63.0, 125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0];

/// One value per octave band of [`OCTAVE_BANDS_HZ`].
pub type Bands = [f32; BAND_COUNT];

/// Index of a material in its scene's material table.
pub type MaterialId = u16;

/// The most materials a scene's table can hold: every id is a [`MaterialId`].
pub const MAX_MATERIALS: usize = MaterialId::MAX as usize + 1;

/// An acoustic surface material. All coefficients are energy fractions in
/// `[0, 1]` per octave band: `absorption` is the fraction not reflected,
/// `scattering` the fraction of the reflected energy that is diffuse, and
/// `transmission` the fraction passing through the surface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    pub absorption: Bands,
    pub scattering: Bands,
    pub transmission: Bands,
}

impl Material {
    /// A material with the same absorption in every band, no scattering and no
    /// transmission.
    pub fn uniform(name: &str, absorption: f32) -> Result<Self> {
        Self {
            name: name.to_owned(),
            absorption: [absorption; BAND_COUNT],
            scattering: [0.0; BAND_COUNT],
            transmission: [0.0; BAND_COUNT],
        }
        .validated()
    }

    /// Checks that every coefficient is a finite fraction and that absorption
    /// and transmission together do not exceed one.
    pub fn validated(self) -> Result<Self> {
        self.check()?;
        Ok(self)
    }

    /// [`Self::validated`] without taking the material.
    pub fn check(&self) -> Result<()> {
        let fail = |reason: String| Error::InvalidMaterial {
            name: self.name.clone(),
            reason,
        };
        for (what, bands) in [
            ("absorption", &self.absorption),
            ("scattering", &self.scattering),
            ("transmission", &self.transmission),
        ] {
            if let Some((b, v)) = bands
                .iter()
                .enumerate()
                .find(|(_, v)| !(0.0..=1.0).contains(*v))
            {
                return Err(fail(format!(
                    "{what} at {} Hz is {v}; it must lie in [0, 1]",
                    OCTAVE_BANDS_HZ[b]
                )));
            }
        }
        let bands = self
            .transmission
            .iter()
            .zip(&self.absorption)
            .zip(OCTAVE_BANDS_HZ);
        for ((&t, &a), hz) in bands {
            if t > a + 1e-6 {
                return Err(fail(format!(
                    "transmission {t} exceeds absorption {a} at {hz} Hz: transmitted energy is not reflected, so it counts as absorbed"
                )));
            }
        }
        Ok(())
    }

    /// Whether any band lets sound through: scenes with no transmitting
    /// material trace no transmission paths.
    pub fn transmits(&self) -> bool {
        self.transmission.iter().any(|&t| t > 0.0)
    }
}

/// Checks a table that replaces one of `current` materials: every
/// material valid, none dropped (triangles refer to every one), at most
/// [`MAX_MATERIALS`]. What a material edit must pass before it is stored,
/// and what a stored table must pass when it is loaded again.
pub fn check_material_table(current: usize, table: &[Material]) -> Result<()> {
    if table.len() < current {
        return Err(Error::MaterialTableShrinks {
            current,
            given: table.len(),
        });
    }
    if table.len() > MAX_MATERIALS {
        return Err(Error::LimitExceeded(format!(
            "{} materials; a scene holds at most {MAX_MATERIALS}",
            table.len()
        )));
    }
    table.iter().try_for_each(Material::check)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_replacement_table_may_grow_but_not_shrink_overflow_or_hold_bad_coefficients() {
        let m = |name: &str| Material::uniform(name, 0.2).unwrap();
        assert!(check_material_table(2, &[m("a"), m("b"), m("c")]).is_ok());
        assert!(matches!(
            check_material_table(2, &[m("a")]),
            Err(Error::MaterialTableShrinks {
                current: 2,
                given: 1
            })
        ));
        let many = vec![m("x"); MAX_MATERIALS + 1];
        assert!(matches!(
            check_material_table(0, &many),
            Err(Error::LimitExceeded(_))
        ));
        let mut bad = m("bad");
        bad.absorption[3] = f32::NAN;
        assert!(matches!(
            check_material_table(0, &[bad]),
            Err(Error::InvalidMaterial { .. })
        ));
    }

    #[test]
    fn rejects_coefficients_outside_unit_range() {
        assert!(Material::uniform("x", 1.5).is_err());
        assert!(Material::uniform("x", f32::NAN).is_err());
        let m = Material::uniform("x", 0.2).unwrap();
        assert!(!m.transmits());
    }
}
