//! Acceptance on real data: the seed envelope chain (adapted to 12 kHz) on the CWRU drive-end
//! recordings, read back from the batch JSON summary.
//!
//! - Inner-race records 105 and 209 with STSA at the BPFI interval: the top envelope-spectrum
//!   peak lies within 1 % of BPFI; outer-race records 130 and 234 with STSA at BPFO: within 1 %
//!   of BPFO.
//! - Controls: STSA is not allowed to manufacture the line it averages at. Averaging the
//!   inner-race records at the BPFO interval (and the outer-race ones at BPFI) must NOT put the
//!   top peak at the hypothesised frequency.

use std::path::{Path, PathBuf};
use std::process::Command;

fn cwru(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cwru").join(name)
}

/// Runs the `envelope_cwru` preset with STSA at `fault` on `file`; returns (top peak Hz, fault
/// frequencies from the JSON).
fn top_peak(file: &str, fault: &str) -> (f64, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.toml");
    std::fs::write(
        &job,
        format!(
            "[input]\npaths = [{:?}]\nchannel = \"_DE_time\"\n[machine]\nbearing = \"SKF 6205-2RS JEM\"\n[chain]\npreset = \"envelope_cwru\"\nfault = \"{fault}\"\n[output]\ndir = \"out\"\nstages = [\"envelope_spectrum\"]\npeaks = 5\n",
            cwru(file).display().to_string()
        ),
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_twinscope")).args(["--batch", job.to_str().unwrap(), "-q"]).output().unwrap();
    assert!(o.status.success(), "{file}: {}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap()).unwrap();
    let input = &summary["inputs"][0];
    let peak = input["outputs"][0]["peaks"][0]["frequency_hz"].as_f64().unwrap();
    (peak, input["fault_frequencies"].clone())
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b
}

#[test]
fn inner_race_records_peak_at_bpfi() {
    for f in ["105_de_inner_007_0hp_12k.mat", "209_de_inner_021_0hp_12k.mat"] {
        let (peak, ff) = top_peak(f, "bpfi");
        let bpfi = ff["bpfi_hz"].as_f64().unwrap();
        assert!(rel(peak, bpfi) < 0.01, "{f}: top peak {peak:.2} Hz, BPFI {bpfi:.2} Hz");
    }
}

#[test]
fn outer_race_records_peak_at_bpfo() {
    for f in ["130_de_outer6_007_0hp_12k.mat", "234_de_outer6_021_0hp_12k.mat"] {
        let (peak, ff) = top_peak(f, "bpfo");
        let bpfo = ff["bpfo_hz"].as_f64().unwrap();
        assert!(rel(peak, bpfo) < 0.01, "{f}: top peak {peak:.2} Hz, BPFO {bpfo:.2} Hz");
    }
}

#[test]
fn stsa_at_the_wrong_interval_does_not_invent_the_line() {
    for (f, wrong, key) in [
        ("105_de_inner_007_0hp_12k.mat", "bpfo", "bpfo_hz"),
        ("209_de_inner_021_0hp_12k.mat", "bpfo", "bpfo_hz"),
        ("130_de_outer6_007_0hp_12k.mat", "bpfi", "bpfi_hz"),
        ("234_de_outer6_021_0hp_12k.mat", "bpfi", "bpfi_hz"),
    ] {
        let (peak, ff) = top_peak(f, wrong);
        let line = ff[key].as_f64().unwrap();
        assert!(rel(peak, line) > 0.01, "{f}: STSA at {wrong} put the top peak at {peak:.2} Hz ≈ {line:.2} Hz");
    }
}
