//! Wavefront OBJ: any bytes give a mesh or an error, never a panic or an absurd allocation; a
//! mesh that is accepted keeps the invariants the renderer relies on.
#![no_main]

use libfuzzer_sys::fuzz_target;
use linpose::render::Mesh;
use std::path::Path;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(m) = Mesh::from_obj_bytes(Path::new("fuzz.obj"), bytes) {
        let n = m.positions().len();
        assert!(m.triangles().iter().flatten().all(|&i| (i as usize) < n));
        assert!(m.positions().iter().flatten().all(|v| v.is_finite()));
        assert!(m.radius() > 0.0 && m.radius().is_finite());
        assert!(m.albedo().iter().all(|a| (0.0..=1.0).contains(a)));
    }
});
