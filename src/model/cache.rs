//! A bounded memo of integrated sensor signals for the model loop.
//!
//! The missing-effect search evaluates hundreds of machines, and many of them differ only in
//! what is applied after the integration: a line search on the noise level (every trial
//! re-fits it), the sensor roll-off or the path modulation, the seed floor's and scatter's
//! re-seeded twins of a machine whose assembly draws nothing from its seed. Those share one
//! integration. [`SimulationCache::simulate`] keys the integrated signal ([`run_raw`]) by
//! everything that shapes it — the machine with its measurement effects, recorder filter and
//! name taken out, and its seed too when assembling it drew no random number
//! ([`Model::seeded_assembly`]) — and applies the measurement effects ([`finish`]) to every
//! call, so a cached result is bit-identical to [`super::simulate`]'s.

use super::assemble::Model;
use super::error::ModelError;
use super::machine::Machine;
use super::simulate::{finish, run_raw};
use crate::signal::Signal;
use std::collections::hash_map::DefaultHasher;
use std::collections::VecDeque;
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, LazyLock, Mutex};

/// Integrated signals, least recently used first out, within a memory budget.
pub struct SimulationCache {
    entries: Mutex<VecDeque<Entry>>,
    capacity_bytes: usize,
    hits: AtomicUsize,
    misses: AtomicUsize,
}

struct Entry {
    hash: u64,
    key: String,
    raw: Arc<Vec<f64>>,
}

impl Entry {
    fn bytes(&self) -> usize {
        self.key.len() + self.raw.len() * std::mem::size_of::<f64>()
    }
}

impl SimulationCache {
    /// An empty cache that keeps at most about `capacity_bytes` of signals and keys.
    pub fn new(capacity_bytes: usize) -> Self {
        Self { entries: Mutex::new(VecDeque::new()), capacity_bytes, hits: AtomicUsize::new(0), misses: AtomicUsize::new(0) }
    }

    /// [`super::simulate`], integrating only when no machine with the same integration key
    /// (see [`integration_key`]) was integrated before. Errors are [`super::simulate`]'s and
    /// are not kept.
    pub fn simulate(&self, machine: &Machine) -> Result<Signal, ModelError> {
        let model = Model::build(machine)?;
        let key = integration_key(&model);
        let hash = {
            let mut h = DefaultHasher::new();
            key.hash(&mut h);
            h.finish()
        };
        if let Some(raw) = self.lookup(hash, &key) {
            self.hits.fetch_add(1, Ordering::Relaxed);
            return finish(&model, &raw);
        }
        self.misses.fetch_add(1, Ordering::Relaxed);
        let raw = Arc::new(run_raw(&model, |_| true)?);
        let out = finish(&model, &raw);
        self.insert(Entry { hash, key, raw });
        out
    }

    /// Forgets every signal (the counts are kept).
    pub fn clear(&self) {
        self.entries.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// (hits, misses) so far.
    pub fn stats(&self) -> (usize, usize) {
        (self.hits.load(Ordering::Relaxed), self.misses.load(Ordering::Relaxed))
    }

    fn lookup(&self, hash: u64, key: &str) -> Option<Arc<Vec<f64>>> {
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let i = entries.iter().position(|e| e.hash == hash && e.key == key)?;
        let e = entries.remove(i)?;
        let raw = e.raw.clone();
        entries.push_back(e);
        Some(raw)
    }

    fn insert(&self, entry: Entry) {
        if entry.bytes() > self.capacity_bytes {
            return;
        }
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        // Two threads may have integrated the same machine at once: keep one copy.
        if entries.iter().any(|e| e.hash == entry.hash && e.key == entry.key) {
            return;
        }
        let mut used: usize = entries.iter().map(Entry::bytes).sum::<usize>() + entry.bytes();
        while used > self.capacity_bytes {
            match entries.pop_front() {
                Some(old) => used -= old.bytes(),
                None => break,
            }
        }
        entries.push_back(entry);
    }
}

/// What shapes a model's integrated signal, as text: its machine less the measurement
/// effects (noise, sensor response, path modulation), the recorder's anti-alias filter and
/// the name, and less the seed when assembly drew nothing from it.
///
/// The text is the machine's `Debug` form: every field, and every f64 in its shortest
/// round-trip form (`-0.0`, `NaN` and `inf` included), so two keys are equal only when every
/// number is.
pub fn integration_key(model: &Model) -> String {
    let mut m = model.machine.clone();
    m.name.clear();
    m.effects.noise = None;
    m.effects.sensor_response = None;
    m.effects.path_modulation = None;
    m.sensor.antialias = None;
    if !model.seeded_assembly {
        m.seed = 0;
    }
    format!("{m:?}")
}

/// The loop's cache: one per process, 128 MB (the search's 1.5 s evaluations are about 150 kB
/// each at 12 kHz, so several hundred fit).
static LOOP_SIMULATIONS: LazyLock<SimulationCache> = LazyLock::new(|| SimulationCache::new(128 << 20));

/// Whether [`simulate_cached`] uses the process's cache (on unless
/// [`set_loop_cache_enabled`] turned it off: `twinscope bench` times the search both ways).
static LOOP_CACHE_ON: AtomicBool = AtomicBool::new(true);

/// [`super::simulate`] through the process's loop cache ([`SimulationCache`]): what the
/// calibration and the missing-effect search call for every evaluation.
pub fn simulate_cached(machine: &Machine) -> Result<Signal, ModelError> {
    if LOOP_CACHE_ON.load(Ordering::Relaxed) {
        LOOP_SIMULATIONS.simulate(machine)
    } else {
        super::simulate(machine)
    }
}

/// Turns the process's loop cache on or off (off: every evaluation integrates, as before the
/// cache; the results are the same either way).
pub fn set_loop_cache_enabled(on: bool) {
    LOOP_CACHE_ON.store(on, Ordering::Relaxed);
}

/// Empties the process's loop cache (its counts are kept).
pub fn clear_loop_cache() {
    LOOP_SIMULATIONS.clear();
}

/// (hits, misses) of the process's loop cache.
pub fn loop_cache_stats() -> (usize, usize) {
    LOOP_SIMULATIONS.stats()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{preset, simulate, EffectKind};

    /// A short CWRU inner-race machine (0.2 s: the cache's behaviour, not the physics).
    fn short(effects: &[EffectKind]) -> Machine {
        let mut m = preset("cwru_6205_inner").unwrap();
        m.duration_s = 0.2;
        m.settle_s = 0.02;
        for k in effects {
            m.effects.enable(*k);
        }
        m
    }

    #[test]
    fn a_machine_differing_only_in_measurement_effects_reuses_the_integration_bit_for_bit() {
        let cache = SimulationCache::new(64 << 20);
        let mut m = short(&[EffectKind::Noise]);
        let first = cache.simulate(&m).unwrap();
        assert_eq!(first.samples, simulate(&m).unwrap().samples);
        assert_eq!(cache.stats(), (0, 1));
        // Another noise level, a sensor roll-off, a path modulation, a recorder filter and a
        // seed the assembly does not draw on: one integration serves them all.
        m.effects.noise.as_mut().unwrap().snr_db -= 7.0;
        m.effects.enable(EffectKind::SensorResponse);
        m.effects.enable(EffectKind::PathModulation);
        m.seed ^= 0xABCD;
        m.name = "renamed".into();
        let again = cache.simulate(&m).unwrap();
        assert_eq!(cache.stats(), (1, 1));
        let direct = simulate(&m).unwrap();
        assert_eq!(again.samples, direct.samples, "a reused integration must give simulate()'s samples exactly");
        assert_ne!(again.samples, first.samples, "the measurement effects must still act");
        assert_eq!(again.meta.extra, direct.meta.extra);
        assert_eq!(again.name, direct.name);
    }

    #[test]
    fn anything_that_shapes_the_integration_is_in_the_key() {
        let cache = SimulationCache::new(64 << 20);
        let m = short(&[]);
        cache.simulate(&m).unwrap();
        let mut stiffer = m.clone();
        stiffer.bearings[0].resonator_frequency_hz *= 1.0 + f64::EPSILON;
        let mut longer = m.clone();
        longer.duration_s += 1.0 / m.fs_hz;
        let mut loaded = m.clone();
        loaded.effects.enable(EffectKind::LoadZone);
        for (what, other) in [("resonance one ulp higher", &stiffer), ("one sample longer", &longer), ("a load zone", &loaded)] {
            let (hits, _) = cache.stats();
            let s = cache.simulate(other).unwrap();
            assert_eq!(cache.stats().0, hits, "{what}: must integrate again");
            assert_eq!(s.samples, simulate(other).unwrap().samples, "{what}");
        }
        assert_eq!(cache.stats(), (0, 4));
    }

    #[test]
    fn the_seed_is_in_the_key_exactly_when_assembly_draws_on_it() {
        let plain = Model::build(&short(&[])).unwrap();
        assert!(!plain.seeded_assembly);
        for k in [EffectKind::Slip, EffectKind::ExtendedFault] {
            let m = short(&[k]);
            assert!(Model::build(&m).unwrap().seeded_assembly, "{}", k.name());
            let cache = SimulationCache::new(64 << 20);
            let a = cache.simulate(&m).unwrap();
            let mut other = m.clone();
            other.seed ^= 0x77;
            let b = cache.simulate(&other).unwrap();
            assert_eq!(cache.stats(), (0, 2), "{}: another seed draws other random numbers", k.name());
            assert_ne!(a.samples, b.samples, "{}", k.name());
            assert_eq!(b.samples, simulate(&other).unwrap().samples, "{}", k.name());
        }
    }

    #[test]
    fn the_memory_budget_holds_and_the_least_recently_used_goes_first() {
        let m = short(&[]);
        let one = (integration_key(&Model::build(&m).unwrap()).len() + (m.duration_s * m.fs_hz).round() as usize * 8) as f64;
        // Room for two entries, not three.
        let cache = SimulationCache::new((2.5 * one) as usize);
        let at = |hz: f64| {
            let mut x = m.clone();
            x.bearings[0].resonator_frequency_hz = hz;
            x
        };
        let (a, b, c) = (at(3000.0), at(3100.0), at(3200.0));
        cache.simulate(&a).unwrap();
        cache.simulate(&b).unwrap();
        cache.simulate(&a).unwrap(); // a is now the most recently used
        assert_eq!(cache.stats(), (1, 2));
        cache.simulate(&c).unwrap(); // evicts b
        cache.simulate(&a).unwrap();
        assert_eq!(cache.stats(), (2, 3));
        cache.simulate(&b).unwrap();
        assert_eq!(cache.stats(), (2, 4), "b was evicted");
        // A cache too small for one signal keeps nothing and still simulates.
        let tiny = SimulationCache::new(16);
        assert_eq!(tiny.simulate(&a).unwrap().samples, simulate(&a).unwrap().samples);
        tiny.simulate(&a).unwrap();
        assert_eq!(tiny.stats(), (0, 2));
    }

    #[test]
    fn an_invalid_machine_is_refused_as_simulate_refuses_it() {
        let cache = SimulationCache::new(1 << 20);
        let mut m = short(&[]);
        m.fs_hz = -1.0;
        assert_eq!(cache.simulate(&m).unwrap_err().to_string(), simulate(&m).unwrap_err().to_string());
    }
}
