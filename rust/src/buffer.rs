//! Large zeroed f64 buffers for the dense normal matrix.
//!
//! On Linux the buffer is an anonymous mapping (zero pages, touched lazily) marked
//! `MADV_HUGEPAGE`: with transparent huge pages in "madvise" mode — the common
//! default — a multi-GB matrix then lives on 2 MiB pages, which cuts the page
//! faults while forming it and the TLB misses while factorising it. Elsewhere
//! it is a plain zeroed allocation. Allocation failure is an error, not an abort.

use crate::error::PodidError;
use std::ops::{Deref, DerefMut};

pub struct DenseBuf {
    ptr: *mut f64,
    len: usize,
}

// SAFETY: DenseBuf owns its memory exclusively, like a Vec<f64>.
unsafe impl Send for DenseBuf {}
unsafe impl Sync for DenseBuf {}

impl DenseBuf {
    /// `len` zeros, or `PodidError::OutOfMemory` naming `what`.
    pub fn zeroed(len: usize, what: &str) -> Result<DenseBuf, PodidError> {
        let oom = || PodidError::OutOfMemory {
            bytes: len as u128 * 8,
            what: what.to_string(),
        };
        let bytes = len.checked_mul(8).ok_or_else(oom)?;
        if len == 0 {
            return Ok(DenseBuf {
                ptr: std::ptr::NonNull::dangling().as_ptr(),
                len: 0,
            });
        }
        let ptr = Self::map(bytes).ok_or_else(oom)?;
        Ok(DenseBuf { ptr, len })
    }

    #[cfg(target_os = "linux")]
    fn map(bytes: usize) -> Option<*mut f64> {
        // SAFETY: a fresh private anonymous mapping; checked for MAP_FAILED.
        unsafe {
            let p = libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            );
            if p == libc::MAP_FAILED {
                return None;
            }
            // advisory only: failure just means ordinary pages
            libc::madvise(p, bytes, libc::MADV_HUGEPAGE);
            Some(p as *mut f64)
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn map(bytes: usize) -> Option<*mut f64> {
        let layout = std::alloc::Layout::from_size_align(bytes, 64).ok()?;
        // SAFETY: non-zero size; null handled by the caller.
        let p = unsafe { std::alloc::alloc_zeroed(layout) } as *mut f64;
        (!p.is_null()).then_some(p)
    }
}

impl Drop for DenseBuf {
    fn drop(&mut self) {
        if self.len == 0 {
            return;
        }
        let bytes = self.len * 8;
        // SAFETY: ptr/bytes are exactly what `map` returned.
        #[cfg(target_os = "linux")]
        unsafe {
            libc::munmap(self.ptr as *mut libc::c_void, bytes);
        }
        #[cfg(not(target_os = "linux"))]
        unsafe {
            std::alloc::dealloc(
                self.ptr as *mut u8,
                std::alloc::Layout::from_size_align_unchecked(bytes, 64),
            );
        }
    }
}

impl Deref for DenseBuf {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        // SAFETY: ptr is valid for len initialised (zeroed) f64s for our lifetime.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl DerefMut for DenseBuf {
    fn deref_mut(&mut self) -> &mut [f64] {
        // SAFETY: as above, and we hold the only reference.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_writable_and_empty() {
        let mut b = DenseBuf::zeroed(3 << 20, "test").unwrap();
        assert!(b.iter().all(|&v| v == 0.0));
        b[12345] = 2.0;
        assert_eq!(b.iter().sum::<f64>(), 2.0);
        assert!(DenseBuf::zeroed(0, "empty").unwrap().is_empty());
    }

    #[test]
    fn impossible_size_is_an_error() {
        for len in [usize::MAX / 4, 1 << 50] {
            let e = DenseBuf::zeroed(len, "huge").err().unwrap();
            assert!(matches!(e, PodidError::OutOfMemory { .. }));
        }
    }
}

/// `n` complex zeros as a `Vec<c64>` from a zeroed allocation (calloc: the OS hands
/// out zero pages, touched lazily by whichever thread fills them), not a serial
/// memset of the whole buffer on the calling thread as `vec![c64::new(0.0, 0.0); n]`
/// does — measured at m = 100, 2000 lines: the 320 MB per evaluation cost ≈ 10 % of
/// the refinement's wall time on one thread while the others waited.
pub fn zeroed_c64(n: usize) -> Vec<faer::c64> {
    let mut v = std::mem::ManuallyDrop::new(vec![0.0f64; 2 * n]);
    let (ptr, len, cap) = (v.as_mut_ptr(), v.len(), v.capacity());
    debug_assert!(len == 2 * n);
    if cap != len {
        // not an exact allocation: fall back to the plain way (never seen)
        unsafe { drop(Vec::from_raw_parts(ptr, len, cap)) };
        return vec![faer::c64::new(0.0, 0.0); n];
    }
    // SAFETY: c64 is #[repr(C)] { re: f64, im: f64 } — size 16, align 8 — so 2n zeroed
    // f64 with capacity exactly 2n are n zeroed c64 with capacity n, and the layout
    // the Vec<c64> frees with (16n bytes, align 8) is the one allocated.
    unsafe { Vec::from_raw_parts(ptr as *mut faer::c64, n, n) }
}

#[cfg(test)]
mod zeroed_tests {
    use super::zeroed_c64;

    #[test]
    fn zeroed_c64_is_zeros_and_usable() {
        for n in [0usize, 1, 7, 1 << 16] {
            let mut v = zeroed_c64(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|z| z.re == 0.0 && z.im == 0.0));
            v.push(faer::c64::new(1.0, -1.0));
            assert_eq!(v[n], faer::c64::new(1.0, -1.0));
        }
    }
}
