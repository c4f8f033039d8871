//! The same training set gives byte-identical model files whatever the number of threads: the
//! sums behind the Gram matrix, the weights, the eigenimages and the factorisations must not
//! change their order with the thread count. Sized like the paper (222 training images of
//! 160 x 120) so every parallel path of the kernels is taken.

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::{Dataset, EigenspaceParams, Estimator, LinearParams, Param, PoseModel, PoseSpace};

/// The paper's training grid (elevation 32..77 every 9, azimuth 0..324 every 9: 6 x 37 = 222)
/// of smooth images with a pseudo-random texture, so the Gram matrix has no special structure.
fn paper_sized() -> Dataset {
    let (w, h) = (160u32, 120u32);
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut feats) = (Vec::new(), Vec::new());
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for el in (32..=77).step_by(9) {
        for az in (0..360).step_by(9) {
            poses.extend([el as f64, az as f64]);
            let (r, lift) = ((az as f64).to_radians(), el as f64 / 90.0 * 0.3);
            for y in 0..h {
                for x in 0..w {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    let (u, v) = (x as f64 / w as f64 - 0.5, y as f64 / h as f64 - 0.5);
                    let d2 = (u - 0.3 * r.cos()).powi(2) + (v - 0.25 * r.sin() + lift).powi(2);
                    let px = 0.8 * (-d2 / 0.02).exp() + 0.1 * (state >> 40) as f64 / (1u64 << 24) as f64;
                    feats.push(((px.clamp(0.0, 1.0) * 255.0).round() / 255.0) as f32);
                }
            }
        }
    }
    Dataset::new(ImageSpec { width: w, height: h, color: ColorMode::Gray }, feats, space, poses).unwrap()
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(f)
}

/// Fits a model and returns its file's bytes.
type Fit<'a> = &'a (dyn Fn(&Dataset) -> Vec<u8> + Sync);

#[test]
fn models_are_byte_identical_across_thread_counts() {
    let data = paper_sized();
    let fits: [(&str, Fit); 3] = [
        ("linear", &|d| LinearParams::default().fit(d).unwrap().to_bytes().unwrap()),
        ("linear, ridge and centred", &|d| LinearParams::default().ridge(1e-3).center(true).fit(d).unwrap().to_bytes().unwrap()),
        ("eigenspace", &|d| EigenspaceParams::default().manifold_step(1.0).fit(d).unwrap().to_bytes().unwrap()),
    ];
    for (name, fit) in fits {
        let one = in_pool(1, || fit(&data));
        let two = in_pool(2, || fit(&data));
        let eight = in_pool(8, || fit(&data));
        assert!(one == two, "{name}: 1 thread and 2 threads give different model files");
        assert!(one == eight, "{name}: 1 thread and 8 threads give different model files");
        // And the estimates of a model do not depend on the threads either.
        let model = linpose::AnyModel::from_bytes(std::path::Path::new(name), &one).unwrap();
        let e1 = in_pool(1, || model.predict(data.features()).unwrap());
        let e2 = in_pool(2, || model.predict(data.features()).unwrap());
        assert!(e1.iter().zip(&e2).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: estimates differ across thread counts");
    }
}
