//! How many threads the CPU work of a frame runs on.

use std::sync::OnceLock;

/// The cores this process may use, asked once: the standard library reads
/// the cgroup's quota files on every call (5% of a small pre-integrated
/// frame's time when each frame asked).
pub fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |t| t.get()))
}
