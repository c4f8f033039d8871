//! dataset.toml: any text gives periods or an error, never a panic. The first line names the
//! parameters of the manifest (comma-separated), the rest is the file.
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
    let (head, body) = text.split_once('\n').unwrap_or(("azimuth,elevation", text));
    let names: Vec<String> = head.split(',').map(String::from).collect();
    if let Ok(periods) = linpose::manifest::parse_dataset_toml(Path::new("dataset.toml"), body, &names) {
        for (k, p) in &periods {
            assert!(names.contains(k));
            if let Some(p) = p {
                assert!(p.is_finite() && *p > 0.0);
            }
        }
    }
}
