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
}

impl Error {
    pub fn message(&self) -> &str {
        match self {
            Error::InvalidInput(m) | Error::DeviceLimit(m) | Error::Gpu(m) => m,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message())
    }
}

impl std::error::Error for Error {}
