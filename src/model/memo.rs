//! A per-thread memo of what a force element takes from time alone.
//!
//! An RK4 step evaluates the forces at t, twice at t + h/2 and at t + h, which is the next
//! step's t: of its four times only two are new. What an element computes from `t` alone
//! (shaft and cage angles, a mesh stiffness, a periodic force's components) is remembered per
//! thread for the last time seen and given back as the very values computed, so every force is
//! bit for bit what it was without the memo.

use std::cell::RefCell;
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

/// One element type's memo: four slots, chosen by key, each `(key, time bits, value)`; key 0
/// (no element has it) marks an empty slot. Declared per element type as a `const`
/// thread-local, `Slots::new(any value)`.
pub(crate) struct Slots<T>([RefCell<(u64, u64, T)>; 4]);

impl<T: Copy> Slots<T> {
    /// Four empty slots; `placeholder` is never given back.
    pub(crate) const fn new(placeholder: T) -> Self {
        let empty = (0, 0, placeholder);
        Self([RefCell::new(empty), RefCell::new(empty), RefCell::new(empty), RefCell::new(empty)])
    }
}

/// `read` of the value at time `t` for the element `id`: of the remembered one when this
/// thread last computed it for the same element at the same time (to the bit), else of the
/// one `fill` writes now over the slot's old value (in place: a bearing's time state is about
/// a kilobyte), which is then remembered. The value is lent, not copied: `fill` and `read`
/// run while the slot is borrowed, so neither may use the same element type's memo (its
/// `RefCell` would panic rather than hand out a slot being written).
#[inline]
pub(crate) fn with_at_time<T: 'static, R>(slots: &'static LocalKey<Slots<T>>, id: &MemoId, t: f64, fill: impl FnOnce(&mut T), read: impl FnOnce(&T) -> R) -> R {
    slots.with(|slots| {
        let slot = &slots.0[(id.0 % 4) as usize];
        let t_bits = t.to_bits();
        {
            let entry = slot.borrow();
            if entry.0 == id.0 && entry.1 == t_bits {
                return read(&entry.2);
            }
        }
        let mut entry = slot.borrow_mut();
        // Marked empty until filled, should `fill` unwind.
        entry.0 = 0;
        fill(&mut entry.2);
        (entry.0, entry.1) = (id.0, t_bits);
        read(&entry.2)
    })
}

/// The value of `compute` at time `t` for the element `id`, through the memo as
/// [`with_at_time`] (copied out: for small values).
#[inline]
pub(crate) fn at_time<T: Copy + 'static>(slots: &'static LocalKey<Slots<T>>, id: &MemoId, t: f64, compute: impl FnOnce() -> T) -> T {
    with_at_time(slots, id, t, |v| *v = compute(), |v| *v)
}
