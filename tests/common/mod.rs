//! Helpers shared by the integration tests.
#![allow(dead_code, unused_macros)]

use std::f64::consts::PI;

/// The drive-end 6205 of the CWRU-like rig the model tests build on (on shaft `motor`, sensed at
/// its resonator), as a TOML `[[bearing]]` table without a fault; a string literal, so it can
/// go into `concat!`.
macro_rules! cwru_de_bearing_toml {
    () => {
        r#"[[bearing]]
name = "de"
shaft = "motor"
catalogue = "SKF 6205-2RS JEM"
radial_clearance_m = 5e-6
hertz_constant_n_per_m_n = 8.0e9
pedestal_mass_kg = 5.0
pedestal_stiffness_n_per_m = 1.5e8
pedestal_damping_n_s_per_m = 3000.0
resonator_frequency_hz = 2600.0
resonator_damping_ratio = 0.04
resonator_mass_kg = 0.05
"#
    };
}

/// SplitMix64 + Box–Muller: a fixed-seed generator whose numbers the tests' tolerances were
/// set against (kept separate from `signal::synth` so the test data never changes with it).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn gauss(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
}

/// Pearson correlation coefficient.
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// The rows of a comma-separated fixture file of numbers (blank lines skipped), as written by
/// the fixture scripts beside it; a file or number that cannot be read fails the test, naming it.
pub fn read_fixture_rows(path: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("fixture {path}: {e}"));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| l.split(',').map(|v| v.trim().parse::<f64>().unwrap_or_else(|e| panic!("fixture {path} row {}: {v:?}: {e}", i + 1))).collect())
        .collect()
}

/// A fixture table of comma-separated fields under one header line (blank lines skipped): the
/// rows without the header, each field trimmed.
pub fn read_fixture_table(path: &str) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("fixture {path}: {e}"));
    text.lines().skip(1).filter(|l| !l.trim().is_empty()).map(|l| l.split(',').map(|v| v.trim().to_string()).collect()).collect()
}

/// A fixture file of one number per line (blank lines skipped).
pub fn read_fixture_column(path: &str) -> Vec<f64> {
    read_fixture_rows(path)
        .into_iter()
        .enumerate()
        .map(|(i, row)| match row[..] {
            [v] => v,
            _ => panic!("fixture {path} row {}: {} values where one was expected", i + 1, row.len()),
        })
        .collect()
}
