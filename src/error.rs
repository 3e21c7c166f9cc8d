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

/// A vector of `n` copies of `value`, or `OutOfMemory` naming `what` when
/// the memory cannot be had: sizes users choose never abort the process.
pub fn try_vec<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        let bytes = (n as u128) * std::mem::size_of::<T>() as u128;
        Error::OutOfMemory(format!("{what} needs {bytes} bytes of memory, which could not be allocated"))
    })?;
    v.resize(n, value);
    Ok(v)
}

/// `items` (exactly `n` of them) collected into a vector whose memory is
/// asked for first, fallibly (see `try_vec`).
pub fn try_collect<U>(n: usize, what: &str, items: impl Iterator<Item = U>) -> Result<Vec<U>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        let bytes = (n as u128) * std::mem::size_of::<U>() as u128;
        Error::OutOfMemory(format!("{what} needs {bytes} bytes of memory, which could not be allocated"))
    })?;
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
    }
}
