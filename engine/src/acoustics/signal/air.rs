//! Air absorption per ISO 9613-1 and the speed of sound.
//!
//! Air absorbs sound through viscosity and heat conduction (growing with the
//! square of frequency) and through the vibrational relaxation of oxygen and
//! nitrogen molecules, whose relaxation frequencies depend on how much water
//! vapour the air holds. That is why a long path loses mostly treble, and why
//! dry air absorbs more than humid air at the same temperature.

use serde::{Deserialize, Serialize};

use crate::scene::{Bands, BAND_COUNT};
use crate::{Error, Result};

/// Reference pressure of ISO 9613-1, kPa.
const REFERENCE_PRESSURE_KPA: f64 = 101.325;
/// Reference temperature of ISO 9613-1 (20 °C), K.
const REFERENCE_TEMPERATURE_K: f64 = 293.15;
/// Triple-point isotherm temperature used for the saturation pressure, K.
const TRIPLE_POINT_K: f64 = 273.16;
/// 0 °C in kelvin.
const ZERO_CELSIUS_K: f64 = 273.15;

/// The state of the air sound travels through.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AirConditions {
    pub temperature_c: f64,
    pub relative_humidity_percent: f64,
    pub pressure_kpa: f64,
}

impl Default for AirConditions {
    /// The conditions ISO 3382 reports reverberation at: 20 °C, 50 % relative
    /// humidity, one standard atmosphere.
    fn default() -> Self {
        Self {
            temperature_c: 20.0,
            relative_humidity_percent: 50.0,
            pressure_kpa: REFERENCE_PRESSURE_KPA,
        }
    }
}

impl AirConditions {
    /// Checks that every value is finite and physically plausible: −60 to
    /// 60 °C (the ISO 9613-1 formulas are not meant for more extreme air),
    /// 0 to 100 % relative humidity and 10 to 200 kPa.
    pub fn validated(self) -> Result<Self> {
        let checks = [
            ("temperature", self.temperature_c, -60.0, 60.0, "°C"),
            (
                "relative humidity",
                self.relative_humidity_percent,
                0.0,
                100.0,
                "%",
            ),
            ("pressure", self.pressure_kpa, 10.0, 200.0, "kPa"),
        ];
        for (what, value, low, high, unit) in checks {
            if !(low..=high).contains(&value) {
                return Err(Error::InvalidAudio(format!(
                    "air {what} is {value} {unit}; it must lie in [{low}, {high}] {unit}"
                )));
            }
        }
        Ok(self)
    }

    /// The pure-tone attenuation coefficient α of ISO 9613-1 (equation 5), in
    /// dB per metre, at frequency `hz`.
    pub fn attenuation_db_per_m(&self, hz: f64) -> f64 {
        let t = self.temperature_c + ZERO_CELSIUS_K;
        let t_rel = t / REFERENCE_TEMPERATURE_K;
        let p_rel = self.pressure_kpa / REFERENCE_PRESSURE_KPA;
        // Molar concentration of water vapour, %, from the relative humidity
        // and the saturation vapour pressure (ISO 9613-1 annex B).
        let saturation_exponent = -6.8346 * (TRIPLE_POINT_K / t).powf(1.261) + 4.6151;
        let h = self.relative_humidity_percent * 10f64.powf(saturation_exponent) / p_rel;
        // Relaxation frequencies of oxygen and nitrogen, Hz.
        let fr_o = p_rel * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h));
        let fr_n = p_rel
            * t_rel.powf(-0.5)
            * (9.0 + 280.0 * h * (-4.170 * (t_rel.powf(-1.0 / 3.0) - 1.0)).exp());
        let f2 = hz * hz;
        let classical = 1.84e-11 / p_rel * t_rel.sqrt();
        let oxygen = 0.01275 * (-2239.1 / t).exp() / (fr_o + f2 / fr_o);
        let nitrogen = 0.1068 * (-3352.0 / t).exp() / (fr_n + f2 / fr_n);
        8.686 * f2 * (classical + t_rel.powf(-2.5) * (oxygen + nitrogen))
    }

    /// The pressure amplitude left per octave band after `distance_m` of
    /// air, 10^(−α·d/20), with α taken at the exact base-2 band centres
    /// 1000·2^k Hz (62.5 Hz to 8 kHz). Negative or NaN distances count as
    /// zero, which leaves the sound unchanged.
    pub fn pressure_factors(&self, distance_m: f64) -> Bands {
        let d = distance_m.max(0.0);
        let mut out = [1.0; BAND_COUNT];
        for (band, factor) in out.iter_mut().enumerate() {
            let alpha = self.attenuation_db_per_m(band_centre_hz(band));
            *factor = 10f64.powf(-alpha * d / 20.0) as f32;
        }
        out
    }

    /// Speed of sound in m/s, 331.3·√(1 + T/273.15) (dry-air approximation;
    /// humidity changes it by well under 1 %).
    pub fn speed_of_sound(&self) -> f64 {
        331.3 * (1.0 + self.temperature_c / ZERO_CELSIUS_K).sqrt()
    }
}

/// The exact base-2 centre of octave band `band`: 1000·2^(band − 4) Hz.
pub(crate) fn band_centre_hz(band: usize) -> f64 {
    1000.0 * 2f64.powi(band as i32 - 4)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air(temperature_c: f64, relative_humidity_percent: f64) -> AirConditions {
        AirConditions {
            temperature_c,
            relative_humidity_percent,
            pressure_kpa: 101.325,
        }
    }

    /// ISO 9613-2 table 2 (computed with ISO 9613-1 at the exact base-10
    /// octave midbands 1000·10^(0.3k) Hz), in dB/km, rounded to 0.1.
    #[test]
    fn matches_the_iso_tables() {
        let rows = [
            (10.0, 70.0, [0.1, 0.4, 1.0, 1.9, 3.7, 9.7, 32.8, 117.0]),
            (20.0, 70.0, [0.1, 0.3, 1.1, 2.8, 5.0, 9.0, 22.9, 76.6]),
            (30.0, 70.0, [0.1, 0.3, 1.0, 3.1, 7.4, 12.7, 23.1, 59.3]),
            (15.0, 20.0, [0.3, 0.6, 1.2, 2.7, 8.2, 28.2, 88.8, 202.0]),
            (15.0, 50.0, [0.1, 0.5, 1.2, 2.2, 4.2, 10.8, 36.2, 129.0]),
        ];
        for (t, rh, table) in rows {
            for (k, expected) in table.into_iter().enumerate() {
                let hz = 1000.0 * 10f64.powf(0.3 * (k as f64 - 4.0));
                let db_per_km = air(t, rh).attenuation_db_per_m(hz) * 1000.0;
                // Table values are rounded to 0.1 dB/km, or to 1 dB/km above 100.
                let tolerance = if expected >= 100.0 { 0.5 } else { 0.051 };
                assert!(
                    (db_per_km - expected).abs() <= tolerance,
                    "{t} °C {rh} %: {hz:.0} Hz gives {db_per_km:.3} dB/km, table {expected}"
                );
            }
        }
    }

    #[test]
    fn default_air_grows_with_frequency_and_gives_known_values() {
        let air = AirConditions::default();
        let mut previous = 0.0;
        for band in 0..BAND_COUNT {
            let alpha = air.attenuation_db_per_m(band_centre_hz(band));
            assert!(alpha > previous);
            previous = alpha;
        }
        // Formula values at 20 °C, 50 %: 4.66 dB/km at 1 kHz, 105.3 at 8 kHz.
        assert!((air.attenuation_db_per_m(1000.0) * 1000.0 - 4.66).abs() < 0.01);
        assert!((air.attenuation_db_per_m(8000.0) * 1000.0 - 105.3).abs() < 0.1);
    }

    #[test]
    fn pressure_factors_follow_the_coefficient() {
        let air = AirConditions::default();
        assert_eq!(air.pressure_factors(0.0), [1.0; BAND_COUNT]);
        assert_eq!(air.pressure_factors(-3.0), [1.0; BAND_COUNT]);
        let factors = air.pressure_factors(100.0);
        for (band, &factor) in factors.iter().enumerate() {
            let alpha = air.attenuation_db_per_m(band_centre_hz(band));
            let db = -20.0 * (factor as f64).log10();
            assert!((db - alpha * 100.0).abs() < 1e-4, "band {band}");
        }
        // 100 m at 8 kHz loses about 10.5 dB: a factor near 0.3.
        assert!((factors[7] - 0.298).abs() < 0.002, "{}", factors[7]);
    }

    #[test]
    fn speed_of_sound_at_known_temperatures() {
        assert!((air(0.0, 50.0).speed_of_sound() - 331.3).abs() < 1e-9);
        assert!((AirConditions::default().speed_of_sound() - 343.2).abs() < 0.05);
    }

    #[test]
    fn validation_rejects_unphysical_air() {
        assert!(AirConditions::default().validated().is_ok());
        for bad in [
            air(f64::NAN, 50.0),
            air(20.0, 120.0),
            air(20.0, -1.0),
            air(-300.0, 50.0),
            AirConditions {
                pressure_kpa: f64::INFINITY,
                ..AirConditions::default()
            },
        ] {
            let err = bad.validated().unwrap_err();
            assert!(matches!(err, Error::InvalidAudio(_)), "{err}");
        }
    }
}
