//! Model files: any bytes give a model or an error, never a panic; a model that loads answers a
//! query (or refuses it) without panicking.
#![cfg_attr(fuzzing, no_main)]

use linpose::PoseModel;
use std::path::Path;

linpose_fuzz::target!(bytes: body);

fn body(bytes: &[u8]) {
    if let Ok(model) = linpose::AnyModel::from_bytes(Path::new("fuzz.safetensors"), bytes) {
        let m = model.meta().spec.features();
        if m <= 1 << 16 {
            let q: Vec<f32> = (0..m).map(|i| (i % 7) as f32 / 7.0).collect();
            let _ = model.predict(&q);
        }
    }
}
