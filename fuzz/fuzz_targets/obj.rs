//! Wavefront OBJ: any bytes give a mesh or an error, never a panic or an absurd allocation; a
//! mesh that is accepted keeps the invariants the renderer relies on.
#![cfg_attr(fuzzing, no_main)]

use linpose::render::Mesh;
use std::path::Path;

linpose_fuzz::target!(bytes: body);

fn body(bytes: &[u8]) {
    if let Ok(m) = Mesh::from_obj_bytes(Path::new("fuzz.obj"), bytes) {
        let n = m.positions().len();
        assert!(m.triangles().iter().flatten().all(|&i| (i as usize) < n));
        assert!(m.positions().iter().flatten().all(|v| v.is_finite()));
        assert!(m.radius() > 0.0 && m.radius().is_finite());
        assert!(m.albedo().iter().all(|a| (0.0..=1.0).contains(a)));
    }
}
