//! dataset.toml: any text gives periods or an error, never a panic. The first line names the
//! parameters of the manifest (comma-separated), the rest is the file.
#![cfg_attr(fuzzing, no_main)]

use std::path::Path;

linpose_fuzz::target!(text: body);

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
