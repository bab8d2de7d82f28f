//! A per-thread memo of what a force element takes from time alone.
//!
//! An RK4 step evaluates the forces at t, twice at t + h/2 and at t + h, which is the next
//! step's t: of its four times only two are new. What an element computes from `t` alone
//! (shaft and cage angles, a mesh stiffness, a periodic force's components) is remembered per
//! thread for the last time seen and given back as the very values computed, so every force is
//! bit for bit what it was without the memo.

use std::cell::Cell;
use std::thread::LocalKey;

/// A force element's key in the memo: unique to each element value (a clone gets a new one),
/// so an entry is never read by another element, nor by one built later at the same address.
/// The memo assumes an element is not changed once it has been evaluated, as a system's boxed
/// elements cannot be.
#[derive(Debug)]
pub struct MemoId(u64);

impl Default for MemoId {
    fn default() -> Self {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        Self(NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
    }
}

impl Clone for MemoId {
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// One element type's memo: four slots, chosen by key, each `(key, time bits, value)`.
pub(crate) type Slots<T> = [Cell<Option<(u64, u64, T)>>; 4];

/// The value of `compute` at time `t` for the element `id`: the remembered one when this
/// thread last computed it for the same element at the same time (to the bit), else
/// computed and remembered.
#[inline]
pub(crate) fn at_time<T: Copy + 'static>(slots: &'static LocalKey<Slots<T>>, id: &MemoId, t: f64, compute: impl FnOnce() -> T) -> T {
    slots.with(|slots| {
        let slot = &slots[(id.0 % 4) as usize];
        if let Some((key, t_bits, value)) = slot.get() {
            if key == id.0 && t_bits == t.to_bits() {
                return value;
            }
        }
        let value = compute();
        slot.set(Some((id.0, t.to_bits(), value)));
        value
    })
}
