//! The core's one error type. Each variant says whose move it is, so the
//! Python binding maps it to an exception class in one place
//! (src/python/errors.rs) without reading the message.

use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum Error {
    /// The caller's input is invalid: a value, shape, config or call order.
    InvalidInput(String),
    /// The request is valid but beyond this device's limits (sizes, counts).
    DeviceLimit(String),
    /// The GPU or its driver failed (no adapter, out of memory, device lost).
    Gpu(String),
    /// Host memory for the request could not be had (a fallible allocation
    /// failed); the process goes on.
    OutOfMemory(String),
    /// The caller asked the work to stop (Ctrl-C) before it finished.
    Interrupted,
}

impl Error {
    pub fn message(&self) -> &str {
        match self {
            Error::InvalidInput(m) | Error::DeviceLimit(m) | Error::Gpu(m) | Error::OutOfMemory(m) => m,
            Error::Interrupted => "interrupted",
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message())
    }
}

impl std::error::Error for Error {}

/// The error for `n` items of `T` that could not be allocated.
fn out_of_memory<T>(n: usize, what: &str) -> Error {
    let bytes = (n as u128) * std::mem::size_of::<T>() as u128;
    Error::OutOfMemory(format!("{what} needs {bytes} bytes of memory, which could not be allocated"))
}

/// A vector of `n` copies of `value`, or `OutOfMemory` naming `what` when
/// the memory cannot be had: sizes users choose never abort the process.
pub fn try_vec<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<T>(n, what))?;
    v.resize(n, value);
    Ok(v)
}

/// `try_vec(n, zero, what)` without writing the zeros: the allocator's
/// zeroed memory (calloc), which for a large image is fresh pages the
/// kernel zeroes when each is first written, by whichever thread writes it,
/// rather than a pass over the whole image before a frame starts.
pub fn try_zeroed<T: bytemuck::Zeroable>(n: usize, what: &str) -> Result<Vec<T>, Error> {
    let layout = std::alloc::Layout::array::<T>(n).map_err(|_| out_of_memory::<T>(n, what))?;
    if layout.size() == 0 {
        return Ok(std::iter::repeat_with(T::zeroed).take(n).collect());
    }
    // SAFETY: the layout's size is not zero; the memory is zeroed, a valid
    // T each (`Zeroable`), and allocated by the global allocator with T's
    // array layout, as a Vec of capacity n frees it.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout) as *mut T;
        if ptr.is_null() {
            return Err(out_of_memory::<T>(n, what));
        }
        huge_pages(ptr as *mut u8, layout.size());
        Ok(Vec::from_raw_parts(ptr, n, n))
    }
}

/// Asks Linux to back the whole 2 MiB pages among `len` bytes from `ptr`
/// with transparent huge pages where it has them (numpy does the same for
/// its arrays of 4 MiB and more): a 2048x2048 float image is 16384 pages
/// of 4 KiB, each a fault when first written, against 32 pages of 2 MiB.
/// Only a hint: errors are ignored.
fn huge_pages(ptr: *mut u8, len: usize) {
    #[cfg(target_os = "linux")]
    if len >= 4 << 20 {
        const HUGE: usize = 2 << 20;
        // The whole 2 MiB pages inside the range.
        let start = (ptr as usize).next_multiple_of(HUGE);
        let end = (ptr as usize + len) / HUGE * HUGE;
        if end > start {
            // SAFETY: the range lies inside the allocation; MADV_HUGEPAGE
            // changes how its pages are backed, never their contents.
            unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (ptr, len);
}

/// `items` (exactly `n` of them) collected into a vector whose memory is
/// asked for first, fallibly (see `try_vec`).
pub fn try_collect<U>(n: usize, what: &str, items: impl Iterator<Item = U>) -> Result<Vec<U>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<U>(n, what))?;
    v.extend(items);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impossible_allocations_are_errors() {
        let err = try_vec(usize::MAX / 8, 0u64, "the test").unwrap_err();
        assert!(matches!(err, Error::OutOfMemory(ref m) if m.contains("the test")), "{err:?}");
        assert_eq!(try_vec(3, 7u8, "x").unwrap(), vec![7, 7, 7]);
        let err = try_zeroed::<f32>(usize::MAX / 8, "the zeroed test").unwrap_err();
        assert!(matches!(err, Error::OutOfMemory(ref m) if m.contains("the zeroed test")), "{err:?}");
        let err = try_zeroed::<f32>(usize::MAX / 2, "a size past isize").unwrap_err();
        assert!(matches!(err, Error::OutOfMemory(ref m) if m.contains("a size past isize")), "{err:?}");
        assert_eq!(try_zeroed::<f32>(5, "x").unwrap(), vec![0.0; 5]);
        assert_eq!(try_zeroed::<[f32; 4]>(0, "x").unwrap(), Vec::<[f32; 4]>::new());
        assert_eq!(try_zeroed::<()>(3, "x").unwrap().len(), 3);
        // Large enough for huge pages: zeros, and writable.
        let mut big = try_zeroed::<f32>(3 << 20, "x").unwrap();
        assert!(big.iter().all(|&v| v.to_bits() == 0));
        big[(3 << 20) - 1] = 1.0;
        assert_eq!(big.iter().sum::<f32>(), 1.0);
    }
}
