//! The one-ray traversal stack: fixed capacity, storage left uninitialised. A traversal runs once
//! per ray, and zeroing its 480 bytes every time cost 3–5 % of GVS's rays per second on the Xeon
//! host (paired runs; no difference on the Zen 5 host). The packet traversal keeps zeroed arrays:
//! this stack with the lanes' entry distances in its entries made it 0.9× as fast.

use std::mem::MaybeUninit;

/// A stack of at most `N` entries of `T`.
pub(crate) struct Stack<T: Copy, const N: usize> {
    items: [MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> Stack<T, N> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Stack { items: [const { MaybeUninit::uninit() }; N], len: 0 }
    }

    /// Push `v`; a full stack drops it (callers size `N` to the tree's deepest need, so it never
    /// is full).
    #[inline(always)]
    pub(crate) fn push(&mut self, v: T) {
        if let Some(slot) = self.items.get_mut(self.len) {
            slot.write(v);
            self.len += 1;
        }
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // `unsafe` allowed here: the storage is left uninitialised (see the module docs).
        #[allow(unsafe_code)]
        // SAFETY: `push` wrote every entry below the old `len`, and `len` only grows there.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

#[cfg(test)]
mod tests {
    use super::Stack;

    #[test]
    fn pops_in_reverse_and_drops_what_does_not_fit() {
        let mut s = Stack::<u32, 3>::new();
        assert_eq!(s.pop(), None);
        for v in 1..=4 {
            s.push(v);
        }
        assert_eq!([s.pop(), s.pop(), s.pop(), s.pop()], [Some(3), Some(2), Some(1), None]);
        s.push(7);
        assert_eq!(s.pop(), Some(7));
    }
}
