//! poses.csv: any text gives a manifest or an error, never a panic.
#![cfg_attr(fuzzing, no_main)]

use std::path::Path;

linpose_fuzz::target!(text: body);

fn body(text: &str) {
    if let Ok((names, images, poses)) = linpose::manifest::parse_poses_csv(Path::new("poses.csv"), text) {
        assert!(!names.is_empty() && !images.is_empty());
        assert_eq!(poses.len(), names.len() * images.len());
        assert!(poses.iter().all(|v| v.is_finite()));
    }
}
