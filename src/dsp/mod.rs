//! Digital signal processing: one file per algorithm, each a set of pure functions on `&[f64]`
//! with its reference named in its doc comment.

pub mod drs;
pub mod envelope;
pub mod error;
pub mod fft;
pub mod kurtogram;
pub mod lowpass;
pub mod normalise;
pub mod path_correction;
pub mod remez;
pub mod resample;
pub mod scf;
pub mod spectrum;
pub mod stsa;
pub mod welch;
pub mod window;

pub use error::DspError;
pub use normalise::rms;
pub use window::Window;
