//! Writes the native march's portable path: the AVX2 modules of src/cpu
//! with their intrinsics taken from src/cpu/lanes.rs (portable Rust)
//! instead of std::arch, without their target-feature attributes and
//! tests. One source for both paths: a change to the march is a change to
//! both, and the portable path's tests hold it to the AVX2 path's images.

use std::fmt::Write;

const MODULES: [&str; 10] =
    ["cells", "codes", "compositing", "isosurface", "lighting", "ops", "projection", "rays8", "sampling", "tracking"];
const INTRINSICS: &str = "use std::arch::x86_64::*;";
const FEATURES: &str = "#[target_feature(enable = \"avx2,fma,f16c\")]";

fn main() {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    let mut all = String::new();
    for name in MODULES {
        let path = format!("src/cpu/{name}.rs");
        println!("cargo:rerun-if-changed={path}");
        let source = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
        assert!(source.contains(INTRINSICS), "{path} must take its intrinsics from one `{INTRINSICS}`");
        // The tests are the AVX2 path's own; they come last in the file.
        let body = match source.find("\n#[cfg(test)]\nmod tests {") {
            Some(at) => &source[..at],
            None => &source,
        };
        let _ = writeln!(all, "pub mod {name} {{");
        for line in body.lines() {
            let trimmed = line.trim();
            if trimmed == FEATURES {
                continue;
            }
            if trimmed == INTRINSICS {
                let _ = writeln!(all, "use crate::cpu::lanes::*;");
                continue;
            }
            let _ = writeln!(all, "{line}");
        }
        let _ = writeln!(all, "}}");
    }
    std::fs::write(format!("{out}/portable_march.rs"), all).expect("writing the portable march");
    println!("cargo:rerun-if-changed=build.rs");
}
