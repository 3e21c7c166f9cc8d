//! Which code a row of rays runs: the model's stage, on the AVX2 path or
//! on the portable path that build.rs makes from the same modules.

use super::*;
use std::sync::atomic::AtomicBool;

/// `$call` with `$t` bound to the march's reader of `$volume`'s texels, and
/// of its normals stored apart where `$lit` (the frame reads them), from
/// the `codes` and `sampling` modules in scope (the AVX2 path's, or the portable path's).
macro_rules! with_reader {
    ($volume:expr, $lit:expr, $t:ident => $call:expr) => {
        match (&$volume.texels, $volume.normals.as_deref().filter(|_| $lit)) {
            (Texels::R8Unorm(x), Some(n)) => {
                let $t = &codes::Apart(codes::R8Unorm(x), n);
                $call
            }
            (Texels::R16Unorm(x), Some(n)) => {
                let $t = &codes::Apart(codes::R16Unorm(x), n);
                $call
            }
            (Texels::R32Float(x), Some(n)) => {
                let $t = &codes::Apart(sampling::R32Float(x), n);
                $call
            }
            (Texels::Rgba32Float(x), _) => {
                let $t = &sampling::Rgba32Float(x);
                $call
            }
            (Texels::Rgba16Snorm(x), _) => {
                let $t = &sampling::Rgba16Snorm(x);
                $call
            }
            (Texels::R32Float(x), _) => {
                let $t = &sampling::R32Float(x);
                $call
            }
            (Texels::R16Snorm(x), _) => {
                let $t = &codes::R16Snorm(x);
                $call
            }
            (Texels::R8Unorm(x), _) => {
                let $t = &codes::R8Unorm(x);
                $call
            }
            (Texels::R16Unorm(x), _) => {
                let $t = &codes::R16Unorm(x);
                $call
            }
            (Texels::R16Float(x), _) => {
                let $t = &codes::R16Float(x);
                $call
            }
            (Texels::Rgba16Float(x), _) => {
                let $t = &codes::Rgba16Float(x);
                $call
            }
        }
    };
}

/// One row's march (`march_row`) by the modules in scope: the model's stage.
macro_rules! march_with {
    ($frame:expr, $clear:expr, $col0:expr, $row:expr, $out:expr, $depth:expr, $halt:expr, $stopped:expr) => {{
        let (frame, clear, col0, row, out, depth, halt, stopped) =
            ($frame, $clear, $col0, $row, $out, $depth, $halt, $stopped);
        let _ = &depth;
        if frame.model == Model::Isosurface {
            with_reader!(frame.volume, frame.lit, t => isosurface::iso(frame, t, col0, row, out, depth, halt, stopped))
        } else if frame.model.projects() {
            with_reader!(frame.volume, false, t => projection::project(frame, t, col0, row, out, halt, stopped))
        } else if frame.unbiased {
            with_reader!(frame.volume, frame.lit, t => tracking::track(frame, t, col0, row, out, halt, stopped))
        } else {
            with_reader!(frame.volume, frame.lit, t => compositing::march(frame, clear, t, col0, row, out, halt, stopped))
        }
    }};
}

/// The march in portable Rust (`lanes`), made by build.rs from the AVX2
/// modules: for CPUs without AVX2, FMA and F16C, and other architectures.
#[allow(unused_unsafe, unused_imports, dead_code, clippy::all)]
mod portable {
    use crate::cpu::{clear, CellBounds, Frame, Model, PreintTable, Stats, Texels, CELL, CHAIN, MAX_STEPS, TILE};
    use std::sync::atomic::AtomicBool;
    include!(concat!(env!("OUT_DIR"), "/portable_march.rs"));

    /// `super::march_row` on the portable path.
    ///
    /// # Safety
    /// The frame passed `super::check`.
    pub(super) unsafe fn march_row(
        frame: &Frame,
        clear: &clear::Clear,
        col0: u32,
        row: u32,
        out: &mut [[f32; 4]; TILE],
        depth: &mut [f32; TILE],
        halt: &AtomicBool,
        stopped: Option<&mut u8>,
    ) -> Stats {
        unsafe { march_with!(frame, clear, col0, row, out, depth, halt, stopped) }
    }
}

/// Which code the native march runs: AVX2 intrinsics, or the same march in
/// portable Rust.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lanes {
    Avx2,
    Portable,
}

impl Lanes {
    pub fn name(self) -> &'static str {
        match self {
            Lanes::Avx2 => "avx2",
            Lanes::Portable => "portable",
        }
    }
}

/// The path this process's frames take: AVX2 where the CPU has AVX2, FMA
/// and F16C, unless PYVR_NATIVE_LANES=portable asks for the portable path
/// (to test it, or to compare its speed); the portable path elsewhere.
pub fn lanes() -> Lanes {
    static CHOSEN: std::sync::LazyLock<Lanes> = std::sync::LazyLock::new(|| {
        let forced = std::env::var("PYVR_NATIVE_LANES").is_ok_and(|v| v.trim() == "portable");
        if !forced && avx2_available() {
            Lanes::Avx2
        } else {
            Lanes::Portable
        }
    });
    *CHOSEN
}

pub(crate) fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") && is_x86_feature_detected!("f16c")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Eight pixels of one row from column `col0` (those past the image's
/// right edge are left transparent), and an isosurface's hit distances.
pub(super) fn march_row(
    frame: &Frame,
    clear: &clear::Clear,
    col0: u32,
    row: u32,
    out: &mut [[f32; 4]; TILE],
    depth: &mut [f32; TILE],
    halt: &AtomicBool,
    stopped: Option<&mut u8>,
) -> Stats {
    #[cfg(target_arch = "x86_64")]
    if lanes() == Lanes::Avx2 {
        // SAFETY: `lanes` checked AVX2, FMA and F16C; `render` the paddings.
        return unsafe { march_with!(frame, clear, col0, row, out, depth, halt, stopped) };
    }
    // SAFETY: `render` checked the paddings.
    unsafe { portable::march_row(frame, clear, col0, row, out, depth, halt, stopped) }
}
