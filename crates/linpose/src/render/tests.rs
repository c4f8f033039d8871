//! Geometric identities of the renderer (see the module doc of each test).

use super::*;

#[test]
fn smoke() {
    let duck = objects::builtin("duck").unwrap();
    let t = std::time::Instant::now();
    for a in 0..10 {
        render(&duck, a as f64 * 30.0, 45.0, &RenderParams::default()).unwrap();
    }
    eprintln!("debug: {:?} per image", t.elapsed() / 10);
    let t = std::time::Instant::now();
    objects::builtin("duck").unwrap();
    eprintln!("build: {:?}", t.elapsed());
}
