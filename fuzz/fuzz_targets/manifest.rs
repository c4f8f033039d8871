//! poses.csv: any text gives a manifest or an error, never a panic.
#![cfg_attr(fuzzing, no_main)]

use std::path::Path;

#[cfg(fuzzing)]
libfuzzer_sys::fuzz_target!(|text: &str| body(text));

/// Without cargo-fuzz: the body run on every file given (the corpus replayed, as CI does).
#[cfg(not(fuzzing))]
fn main() {
    linpose_fuzz::replay_str(body);
}

fn body(text: &str) {
    if let Ok((names, images, poses)) = linpose::manifest::parse_poses_csv(Path::new("poses.csv"), text) {
        assert!(!names.is_empty() && !images.is_empty());
        assert_eq!(poses.len(), names.len() * images.len());
        assert!(poses.iter().all(|v| v.is_finite()));
    }
}
