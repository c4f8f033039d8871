//! End-to-end tests of the `linpose` command on data sets the tests make.

mod util;

use std::process::Command;
use util::{blob_image, write_dataset, Dir};

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn train_then_eval_on_a_turntable_set() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 5, &[], (32, 24));
    d.ok(&["train", "--data", "data", "--train-step", "10", "--out", "m.safetensors", "--json", "train.json"]);
    let t = json(&d.path("train.json"));
    assert_eq!(t["n_train"], 36);
    assert_eq!(t["method"], "linear");
    assert!(t["fit_s"].as_f64().unwrap() >= 0.0);
    assert_eq!(t["model_bytes"].as_u64().unwrap(), 2 * 32 * 24 * 4 + 2 * 8);
    let out = d.ok(&["eval", "--model", "m.safetensors", "--data", "data", "--json", "eval.json"]);
    assert!(out.contains("unseen"), "{out}");
    let e = json(&d.path("eval.json"));
    assert_eq!(e["n_eval"], 72);
    assert_eq!(e["n_train"], 36);
    assert_eq!(e["method"], "linear");
    for key in ["mean_deg", "median_deg", "p90_deg", "max_deg"] {
        assert!(e["all"][key].is_f64() && e["unseen"][key].is_f64(), "{key}");
    }
    let samples = e["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 72);
    assert_eq!(samples.iter().filter(|s| s["seen"] == true).count(), 36);
    // Seen views are reproduced (the exact fit); unseen ones are estimated to a few degrees.
    for s in samples.iter().filter(|s| s["seen"] == true) {
        assert!(s["error_deg"].as_f64().unwrap() < 1e-2, "{s}");
    }
    assert!(e["unseen"]["mean_deg"].as_f64().unwrap() < 5.0, "{}", e["unseen"]);
    for key in ["image", "true", "estimated", "error_deg", "seen"] {
        assert!(samples[0].get(key).is_some(), "{key}");
    }
}

#[test]
fn eval_with_noise_is_reproducible_and_worse() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 5, &[], (32, 24));
    d.ok(&["train", "--data", "data", "--train-step", "10", "--out", "m.safetensors"]);
    d.ok(&["eval", "--model", "m.safetensors", "--data", "data", "--json", "clean.json"]);
    d.ok(&["eval", "--model", "m.safetensors", "--data", "data", "--noise", "0.1", "--seed", "3", "--json", "n1.json"]);
    d.ok(&["eval", "--model", "m.safetensors", "--data", "data", "--noise", "0.1", "--seed", "3", "--json", "n2.json"]);
    let (c, n1, n2) = (json(&d.path("clean.json")), json(&d.path("n1.json")), json(&d.path("n2.json")));
    assert_eq!(n1["samples"], n2["samples"]);
    assert_eq!(n1["noise"], 0.1);
    assert!(n1["all"]["mean_deg"].as_f64().unwrap() > c["all"]["mean_deg"].as_f64().unwrap());
}

#[test]
fn two_parameter_set_and_predict() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 15, &[20.0, 35.0, 50.0], (40, 30));
    d.ok(&["train", "--data", "data", "--out", "m.safetensors"]);
    let out = d.ok(&["predict", "--model", "m.safetensors", "data/e35_a45.png", "data/e50_a300.png"]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2, "{out}");
    assert!(lines[0].starts_with("data/e35_a45.png\televation=35.0") && lines[0].contains("azimuth=45.0"), "{out}");
    let out = d.ok(&["predict", "--model", "m.safetensors", "--json", "data/e20_a0.png"]);
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert!((v["pose"]["elevation"].as_f64().unwrap() - 20.0).abs() < 1e-3);
    // A folder estimates every image in it.
    let out = d.ok(&["predict", "--model", "m.safetensors", "data"]);
    assert_eq!(out.lines().count(), 72);
}

#[test]
fn coil_layout_is_read_directly() {
    let d = Dir::new();
    let dir = d.path("coil");
    std::fs::create_dir_all(&dir).unwrap();
    for k in 0..72u32 {
        blob_image(24, 24, 30.0, 5.0 * k as f64).save(dir.join(format!("obj3__{k}.png"))).unwrap();
        blob_image(24, 24, 60.0, 5.0 * k as f64).save(dir.join(format!("obj4__{k}.png"))).unwrap();
    }
    std::fs::write(dir.join("README.txt"), "not an image").unwrap();
    std::fs::write(dir.join("obj3__x.png"), "ignored: not a view number").unwrap();
    d.ok(&["train", "--data", "coil", "--object", "3", "--train-step", "10", "--out", "m.safetensors"]);
    d.ok(&["eval", "--model", "m.safetensors", "--data", "coil", "--object", "3", "--json", "e.json"]);
    let e = json(&d.path("e.json"));
    assert_eq!(e["n_eval"], 72);
    assert_eq!(e["samples"][1]["true"][0], 5.0);
    d.fails(&["train", "--data", "coil", "--object", "9", "--out", "m2"], &["no COIL images of object 9"]);
}

#[test]
fn model_loads_in_safetensors_and_reproduces_estimates() {
    // What numpy's safetensors loader sees: the same bytes, read with the reference crate.
    let d = Dir::new();
    write_dataset(&d.path("data"), 10, &[], (16, 12));
    d.ok(&["train", "--data", "data", "--out", "m.safetensors"]);
    let bytes = std::fs::read(d.path("m.safetensors")).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let w = st.tensor("weights").unwrap();
    assert_eq!(w.shape(), [2, 16 * 12]);
    assert_eq!(w.dtype(), safetensors::Dtype::F32);
    let w: Vec<f32> = w.data().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    let img = image::open(d.path("data/a070.png")).unwrap().to_luma8();
    let x: Vec<f64> = img.as_raw().iter().map(|&v| v as f64 / 255.0).collect();
    let c: f64 = w[..192].iter().zip(&x).map(|(&a, &b)| a as f64 * b).sum();
    let s: f64 = w[192..].iter().zip(&x).map(|(&a, &b)| a as f64 * b).sum();
    let az = s.atan2(c).to_degrees().rem_euclid(360.0);
    let out = d.ok(&["predict", "--model", "m.safetensors", "data/a070.png"]);
    let printed: f64 = out.trim().split("azimuth=").nth(1).unwrap().parse().unwrap();
    assert!((az - printed).abs() < 1e-3, "{az} vs {printed}");
    assert!((az - 70.0).abs() < 1e-3);
}

#[test]
fn explicit_training_list_and_rgb_features() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 10, &[], (16, 12));
    std::fs::write(
        d.path("list.txt"),
        "# every 30 degrees\na000.png\na030.png\na060.png\na090.png\na120.png\na150.png\na180.png\na210.png\na240.png\na270.png\na300.png\na330.png\n",
    )
    .unwrap();
    d.ok(&["train", "--data", "data", "--train-list", "list.txt", "--out", "m.safetensors", "--json", "t.json"]);
    assert_eq!(json(&d.path("t.json"))["n_train"], 12);
    d.ok(&["eval", "--model", "m.safetensors", "--data", "data", "--json", "e.json"]);
    assert_eq!(json(&d.path("e.json"))["unseen"]["n"], 24);
    std::fs::write(d.path("bad.txt"), "a000.png\nnot-there.png\n").unwrap();
    d.fails(&["train", "--data", "data", "--train-list", "bad.txt", "--out", "m2"], &["not-there.png", "not in the data set"]);
    // Colour images: gray by Rec. 601 luma by default, three features per pixel with --color rgb.
    let rgb = d.path("rgb");
    std::fs::create_dir_all(&rgb).unwrap();
    let mut csv = String::from("image,azimuth\n");
    for az in (0..360).step_by(10) {
        let g = util::blob_image(16, 12, 30.0, az as f64);
        let c = image::RgbImage::from_fn(16, 12, |x, y| {
            let v = g.get_pixel(x, y).0[0];
            image::Rgb([v, v / 2, 255 - v])
        });
        c.save(rgb.join(format!("c{az}.png"))).unwrap();
        csv.push_str(&format!("c{az}.png,{az}\n"));
    }
    std::fs::write(rgb.join("poses.csv"), csv).unwrap();
    d.ok(&["train", "--data", "rgb", "--out", "g.safetensors", "--json", "g.json"]);
    d.ok(&["train", "--data", "rgb", "--color", "rgb", "--out", "c.safetensors", "--json", "c.json"]);
    assert_eq!(json(&d.path("g.json"))["n_features"], 16 * 12);
    assert_eq!(json(&d.path("c.json"))["n_features"], 16 * 12 * 3);
    // The model remembers its colour handling: predict needs no flag.
    let out = d.ok(&["predict", "--model", "c.safetensors", "rgb/c40.png"]);
    assert!(out.contains("azimuth=40.0"), "{out}");
}

mod bad_input {
    use super::*;

    fn data(d: &Dir) {
        write_dataset(&d.path("data"), 10, &[], (16, 12));
    }

    #[test]
    fn missing_image() {
        let d = Dir::new();
        data(&d);
        std::fs::remove_file(d.path("data/a050.png")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["a050.png", "No such file"]);
        assert!(!d.path("m").exists());
    }

    #[test]
    fn unreadable_image() {
        let d = Dir::new();
        data(&d);
        std::fs::write(d.path("data/a050.png"), b"\x89PNG\r\n\x1a\nthis is not really a png").unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["a050.png", "decode"]);
        std::fs::write(d.path("data/a050.png"), b"").unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["a050.png", "empty"]);
    }

    #[test]
    fn image_of_another_size() {
        let d = Dir::new();
        data(&d);
        blob_image(20, 12, 30.0, 50.0).save(d.path("data/a050.png")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["a050.png", "20x12", "16x12"]);
    }

    #[test]
    fn non_numeric_and_missing_pose_values() {
        let d = Dir::new();
        data(&d);
        let csv = std::fs::read_to_string(d.path("data/poses.csv")).unwrap();
        std::fs::write(d.path("data/poses.csv"), csv.replace("a020.png,20", "a020.png,twenty")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["poses.csv:4", "not a number", "twenty"]);
        std::fs::write(d.path("data/poses.csv"), csv.replace("a020.png,20", "a020.png,")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["poses.csv:4", "missing value"]);
    }

    #[test]
    fn empty_data_set() {
        let d = Dir::new();
        std::fs::create_dir_all(d.path("data")).unwrap();
        std::fs::write(d.path("data/poses.csv"), "image,azimuth\n").unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["empty"]);
        d.fails(&["train", "--data", "nowhere", "--out", "m"], &["nowhere", "no such folder"]);
        std::fs::remove_file(d.path("data/poses.csv")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["no poses.csv"]);
    }

    #[test]
    fn duplicate_images_with_different_poses() {
        let d = Dir::new();
        data(&d);
        std::fs::copy(d.path("data/a000.png"), d.path("data/a180.png")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "m"], &["a000.png", "a180.png", "identical", "--ridge"]);
    }

    #[test]
    fn truncated_model_and_other_format_version() {
        let d = Dir::new();
        data(&d);
        d.ok(&["train", "--data", "data", "--out", "m.safetensors"]);
        let bytes = std::fs::read(d.path("m.safetensors")).unwrap();
        std::fs::write(d.path("cut.safetensors"), &bytes[..bytes.len() - 100]).unwrap();
        d.fails(&["eval", "--model", "cut.safetensors", "--data", "data"], &["cut.safetensors", "not a linpose model file"]);
        std::fs::write(d.path("tiny.safetensors"), &bytes[..5]).unwrap();
        d.fails(&["predict", "--model", "tiny.safetensors", "data/a000.png"], &["tiny.safetensors"]);
        let text = bytes.clone();
        let current = format!("\"format_version\":\"{}", linpose::model_file::FORMAT_VERSION);
        let pos = text.windows(current.len()).position(|w| w == current.as_bytes()).expect("version in header");
        // One more than the current version (a single digit here), and version 1.
        let newer = b'0' + linpose::model_file::FORMAT_VERSION as u8 + 1;
        for (v, whose) in [(newer, "newer"), (b'1', "earlier")] {
            let mut other = bytes.clone();
            other[pos + 18] = v;
            std::fs::write(d.path("other.safetensors"), &other).unwrap();
            let version = format!("format version {}", v as char);
            d.fails(
                &["eval", "--model", "other.safetensors", "--data", "data"],
                &[&version, whose, &format!("reads version {}", linpose::model_file::FORMAT_VERSION), "retrain"],
            );
        }
        d.fails(&["eval", "--model", "data/a000.png", "--data", "data"], &["a000.png", "not a linpose model file"]);
    }

    #[test]
    fn query_image_of_the_wrong_size() {
        let d = Dir::new();
        data(&d);
        d.ok(&["train", "--data", "data", "--out", "m.safetensors"]);
        blob_image(8, 8, 30.0, 0.0).save(d.path("small.png")).unwrap();
        d.fails(&["predict", "--model", "m.safetensors", "small.png"], &["small.png", "8x8", "16x12"]);
        let other = d.path("other");
        write_dataset(&other, 10, &[], (8, 8));
        d.fails(&["eval", "--model", "m.safetensors", "--data", "other"], &["8x8", "16x12"]);
    }

    #[test]
    fn bad_arguments() {
        let d = Dir::new();
        data(&d);
        d.fails(&["train", "--data", "data", "--train-step", "0", "--out", "m"], &["train step"]);
        d.fails(&["train", "--data", "data", "--train-step", "-5", "--out", "m"], &["train step"]);
        d.fails(&["train", "--data", "data", "--ridge", "-1", "--out", "m"], &["ridge"]);
        std::fs::create_dir(d.path("adir")).unwrap();
        d.fails(&["train", "--data", "data", "--out", "adir"], &["adir", "folder"]);
        d.ok(&["train", "--data", "data", "--out", "m.safetensors"]);
        d.fails(&["eval", "--model", "m.safetensors", "--data", "data", "--noise", "1.5"], &["noise", "[0, 1]"]);
    }
}

/// `train --stream` with more images than pixels: least squares through X^T X, read in blocks by
/// a reader thread and summed in 8-bit integer arithmetic, gives the in-memory ridge model, the
/// same file on 1 and 3 threads, and says which path it took.
#[test]
fn streamed_training_matches_the_in_memory_ridge_fit() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 2, &[20.0, 35.0, 50.0, 65.0], (12, 9)); // 720 images > 108 pixels
    let weights = |file: &str| -> Vec<f64> {
        let bytes = std::fs::read(d.path(file)).unwrap();
        let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
        let w = st.tensor("weights").unwrap();
        w.data().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64).collect()
    };
    d.ok(&["train", "--data", "data", "--ridge", "1e-3", "--in-memory", "--no-normalize", "--out", "mem.safetensors"]);
    let out = Command::new(env!("CARGO_BIN_EXE_linpose"))
        .args(["train", "--stream", "--data", "data", "--ridge", "1e-3", "--out", "s1.safetensors"])
        .env("RAYON_NUM_THREADS", "1")
        .current_dir(d.path(""))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    // The integer kernels run where AVX-512 VNNI does (and LINPOSE_SIMD does not cap it).
    #[cfg(target_arch = "x86_64")]
    let vnni = std::env::var_os("LINPOSE_SIMD").is_none()
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vnni");
    #[cfg(not(target_arch = "x86_64"))]
    let vnni = false;
    let arithmetic = if vnni { "8-bit integer" } else { ", f64" };
    assert!(err.contains("X^T X") && err.contains(arithmetic), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_linpose"))
        .args(["train", "--stream", "--data", "data", "--ridge", "1e-3", "--out", "s3.safetensors"])
        .env("RAYON_NUM_THREADS", "3")
        .current_dir(d.path(""))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read(d.path("s1.safetensors")).unwrap() == std::fs::read(d.path("s3.safetensors")).unwrap(), "thread count changes the model");
    let (want, got) = (weights("mem.safetensors"), weights("s1.safetensors"));
    let num: f64 = want.iter().zip(&got).map(|(a, b)| (a - b) * (a - b)).sum();
    let den: f64 = want.iter().map(|a| a * a).sum();
    eprintln!("streamed against in-memory: relative difference {:.2e}", (num / den).sqrt());
    assert!((num / den).sqrt() < 1e-6, "relative difference {}", (num / den).sqrt());
}

#[test]
fn synth_renders_a_generated_object_reproducibly() {
    let d = Dir::new();
    let args = |out: &'static str| ["synth", "--random", "3", "--out", out, "--size", "40x30", "--azimuth", "0:350:10", "--elevation", "32"];
    let out = d.ok(&args("a"));
    assert!(out.contains("random-3"), "{out}");
    d.ok(&args("b"));
    let poses = std::fs::read_to_string(d.path("a/poses.csv")).unwrap();
    assert_eq!(poses.lines().count(), 1 + 36, "{poses}");
    assert!(poses.starts_with("image,elevation,azimuth\ne032.0_a000.0.png,32,0\n"), "{poses}");
    for line in poses.lines().skip(1) {
        let name = line.split(',').next().unwrap();
        let (a, b) = (std::fs::read(d.path(&format!("a/{name}"))).unwrap(), std::fs::read(d.path(&format!("b/{name}"))).unwrap());
        assert_eq!(a, b, "{name} differs between two runs");
        let img = image::load_from_memory(&a).unwrap().to_luma8();
        assert_eq!(img.dimensions(), (40, 30));
        assert!(img.pixels().any(|p| p.0[0] > 0), "{name} is empty");
    }
    let err = d.fails(&["synth", "--random", "3", "--object", "duck", "--out", "c"], &["--random", "--object"]);
    assert!(err.contains("cannot be used with"), "{err}");
    assert!(!d.path("c").exists());
    assert!(d.ok(&["synth", "--list"]).contains("--random SEED"));
}

#[test]
fn synth_jitters_each_view_and_records_it() {
    let d = Dir::new();
    let base = ["synth", "--object", "duck", "--size", "64x48", "--azimuth", "0:90:30", "--elevation", "40"];
    let with =
        |out: &'static str, extra: &[&'static str]| -> Vec<&'static str> { base.iter().copied().chain(["--out", out]).chain(extra.iter().copied()).collect() };
    d.ok(&with("plain", &[]));
    assert!(d.ok(&with("a", &["--jitter", "4,0.1,0.2", "--jitter-seed", "5"])).contains("jitter.csv"));
    d.ok(&with("b", &["--jitter", "4,0.1,0.2", "--jitter-seed", "5"]));
    d.ok(&with("zero", &["--jitter", "0,0,0"]));
    assert!(!d.path("plain/jitter.csv").exists());
    let csv = std::fs::read_to_string(d.path("a/jitter.csv")).unwrap();
    assert_eq!(csv, std::fs::read_to_string(d.path("b/jitter.csv")).unwrap(), "the same seed, the same draws");
    assert!(csv.starts_with("image,dx,dy,scale,exposure\ne040.0_a000.0.png,"), "{csv}");
    let mut moved = 0;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
        assert!(v[0].abs() <= 4.0 && v[1].abs() <= 4.0 && (0.9..=1.1).contains(&v[2]) && (0.8..=1.2).contains(&v[3]), "{line}");
        let read = |dir: &str| std::fs::read(d.path(&format!("{dir}/{}", f[0]))).unwrap();
        assert_eq!(read("a"), read("b"), "{}", f[0]);
        assert_eq!(read("zero"), read("plain"), "no jitter, the registered image: {}", f[0]);
        moved += usize::from(read("a") != read("plain"));
    }
    assert_eq!(moved, 4);
    d.fails(&with("c", &["--jitter", "4,0.1"]), &["jitter", "4,0.1", "SHIFT,SCALE,EXPOSURE"]);
    d.fails(&with("c", &["--jitter", "4,0.3,0"]), &["jitter scale", "fill"]);
    assert!(!d.path("c").exists());
}

#[test]
fn synth_steps_through_roll_and_light() {
    let d = Dir::new();
    let base = ["synth", "--object", "cap", "--size", "48x36", "--azimuth", "0:90:45", "--elevation", "40"];
    let with =
        |out: &'static str, extra: &[&'static str]| -> Vec<&'static str> { base.iter().copied().chain(["--out", out]).chain(extra.iter().copied()).collect() };
    d.ok(&with("plain", &[]));
    d.ok(&with("zero", &["--roll", "0"]));
    d.ok(&with("both", &["--roll", "-20:20:20", "--light", "0:300:60"]));
    let csv = |dir: &str| std::fs::read_to_string(d.path(&format!("{dir}/poses.csv"))).unwrap();
    let toml = |dir: &str| std::fs::read_to_string(d.path(&format!("{dir}/dataset.toml"))).unwrap();
    assert_eq!(csv("plain").lines().next(), Some("image,elevation,azimuth"));
    assert_eq!(toml("plain"), "azimuth = { period = 360 }\nelevation = { linear = true }\n");
    // 3 azimuths x 3 rolls x 6 lights, the columns in their fixed order.
    let both = csv("both");
    assert_eq!(both.lines().count(), 1 + 3 * 3 * 6);
    assert!(both.starts_with("image,elevation,azimuth,roll,light\ne040.0_a000.0_r-20.0_l000.0.png,40,0,-20,0\n"), "{both}");
    assert!(both.lines().all(|l| l.split(',').count() == 5));
    assert_eq!(toml("both"), "azimuth = { period = 360 }\nelevation = { linear = true }\nroll = { linear = true }\nlight = { period = 360 }\n");
    // Roll 0 is no roll, byte for byte.
    for line in csv("plain").lines().skip(1) {
        let name = line.split(',').next().unwrap();
        let rolled = name.replace(".png", "_r000.0.png");
        assert_eq!(std::fs::read(d.path(&format!("plain/{name}"))).unwrap(), std::fs::read(d.path(&format!("zero/{rolled}"))).unwrap(), "{name}");
    }
    // A bad spec names the flag and the value, and nothing is written.
    d.fails(&with("bad", &["--roll", "0:10:0"]), &["--roll 0:10:0", "STEP must be positive"]);
    d.fails(&with("bad", &["--light", "0:x:10"]), &["--light 0:x:10", "STOP"]);
    d.fails(&with("bad", &["--roll", "0:999999:1", "--light", "0:999999:1"]), &["3 azimuths x 1000000 rolls x 1000000 lights", "at most"]);
    assert!(!d.path("bad").exists());
    // A negative START follows its flag as it is.
    d.ok(&[
        "synth",
        "--object",
        "cap",
        "--size",
        "16x12",
        "--azimuth",
        "-10:10:10",
        "--elevation",
        "-20",
        "--roll",
        "-90",
        "--light",
        "-45",
        "--out",
        "negative",
    ]);
    assert!(csv("negative").contains("\ne-20.0_a-10.0_r-90.0_l-45.0.png,-20,-10,-90,-45\n"), "{}", csv("negative"));
}

#[test]
fn normalized_models_take_jittered_views_and_name_the_images_they_refuse() {
    let d = Dir::new();
    let synth = |out: &'static str, extra: &[&'static str]| {
        let mut a = vec!["synth", "--object", "duck", "--size", "80x60", "--azimuth", "0:350:10", "--elevation", "40", "--out", out];
        a.extend_from_slice(extra);
        d.ok(&a);
    };
    synth("reg", &[]);
    synth("jit", &["--jitter", "4,0.1,0.2", "--jitter-seed", "2"]);
    let out = d.run(&[
        "train",
        "--data",
        "reg",
        "--train-step",
        "20",
        "--method",
        "eigenspace",
        "--components",
        "8",
        "--normalize",
        "--out",
        "n.st",
        "--json",
        "t.json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("normalised: object centred and scaled"));
    assert!(json(&d.path("t.json"))["normalize"]["radius"].is_f64());
    let text = d.ok(&["eval", "--model", "n.st", "--data", "jit", "--json", "e.json"]);
    assert!(text.contains("unseen error against the jitter") && text.contains("shift"), "{text}");
    let e = json(&d.path("e.json"));
    assert!(e["unseen"]["mean_deg"].as_f64().unwrap() < 3.0, "{}", e["unseen"]);
    let bins = e["by_jitter"].as_array().unwrap();
    assert_eq!(bins.iter().filter(|b| b["axis"] == "shift").count(), 4);
    // A black image and a moved copy of a view: the first refused with the reason, the second
    // estimated; the exit code says one failed.
    image::GrayImage::new(80, 60).save(d.path("black.png")).unwrap();
    std::fs::copy(d.path("jit/e040.0_a000.0.png"), d.path("view.png")).unwrap();
    let out = d.run(&["predict", "--model", "n.st", "black.png", "view.png"]);
    assert_eq!(out.status.code(), Some(3));
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(stderr.contains("black.png: refused: cannot normalise: no object found") && stderr.contains("1 of 2 images"), "{stderr}");
    assert!(stdout.starts_with("view.png\t") && !stdout.contains("black.png"), "{stdout}");
    d.fails(&["train", "--data", "reg", "--normalize", "--stream", "--out", "s.st"], &["--stream", "normalisation"]);
    d.fails(&["train", "--data", "reg", "--normalize", "sideways", "--out", "s.st"], &["sideways"]);
}

#[test]
fn tiff_data_set_trains_the_png_model_and_jpeg_queries_estimate_alike() {
    // A rendered set as PNG and the same pixels as TIFF (lossless): the same model, byte for
    // byte. An unseen view as JPEG (lossy) is estimated within a degree or two of its PNG.
    let d = Dir::new();
    d.ok(&["synth", "--object", "duck", "--size", "32x24", "--azimuth", "0:350:10", "--elevation", "40", "--out", "png"]);
    std::fs::create_dir_all(d.path("tif")).unwrap();
    std::fs::copy(d.path("png/dataset.toml"), d.path("tif/dataset.toml")).unwrap();
    let poses = std::fs::read_to_string(d.path("png/poses.csv")).unwrap();
    let mut tif_poses = String::new();
    for (k, line) in poses.lines().enumerate() {
        if k == 0 {
            tif_poses.push_str(line);
        } else {
            let (name, pose) = line.split_once(',').unwrap();
            let tif = name.replace(".png", ".tif");
            image::open(d.path(&format!("png/{name}"))).unwrap().save(d.path(&format!("tif/{tif}"))).unwrap();
            tif_poses.push_str(&format!("{tif},{pose}"));
        }
        tif_poses.push('\n');
    }
    std::fs::write(d.path("tif/poses.csv"), tif_poses).unwrap();
    assert_eq!(&std::fs::read(d.path("tif/e040.0_a000.0.tif")).unwrap()[..4], b"II*\0");

    d.ok(&["train", "--data", "png", "--train-step", "20", "--out", "png.safetensors"]);
    d.ok(&["train", "--data", "tif", "--train-step", "20", "--out", "tif.safetensors"]);
    assert!(std::fs::read(d.path("png.safetensors")).unwrap() == std::fs::read(d.path("tif.safetensors")).unwrap(), "TIFF and PNG models differ");

    // eval reads the TIFF set as it reads the PNG one; predict takes a folder of TIFFs.
    d.ok(&["eval", "--model", "png.safetensors", "--data", "png", "--json", "png.json"]);
    d.ok(&["eval", "--model", "png.safetensors", "--data", "tif", "--json", "tif.json"]);
    let estimates = |f: &str| json(&d.path(f))["samples"].as_array().unwrap().iter().map(|s| s["estimated"].clone()).collect::<Vec<_>>();
    assert_eq!(estimates("png.json"), estimates("tif.json"));
    assert_eq!(d.ok(&["predict", "--model", "png.safetensors", "tif"]).lines().count(), 36);

    // An unseen view (azimuth 50; training views every 20 degrees) as a JPEG of quality 90.
    let view = image::open(d.path("png/e040.0_a050.0.png")).unwrap().to_luma8();
    let mut jpg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpg, 90).encode_image(&view).unwrap();
    std::fs::write(d.path("view.jpg"), jpg).unwrap();
    let azimuth = |img: &str| -> f64 {
        let out = d.ok(&["predict", "--model", "png.safetensors", "--json", img]);
        serde_json::from_str::<serde_json::Value>(out.trim()).unwrap()["pose"]["azimuth"].as_f64().unwrap()
    };
    let (png, jpg) = (azimuth("png/e040.0_a050.0.png"), azimuth("view.jpg"));
    let diff = (png - jpg + 180.0).rem_euclid(360.0) - 180.0;
    eprintln!("azimuth of the unseen view: PNG {png:.3}, JPEG {jpg:.3}");
    assert!(diff.abs() < 2.0, "PNG {png}, JPEG {jpg}");
    assert!((png - 50.0).abs() < 10.0, "PNG estimate {png}");
}

/// Four pose parameters end to end: a set with roll and light trains, predicts and evaluates; the
/// error is the camera's rotation angle, the light apart, and every parameter's own error is in
/// eval's JSON and printed under the table.
#[test]
fn four_parameters_train_predict_and_evaluate() {
    let d = Dir::new();
    let grid = ["--size", "32x24", "--azimuth", "0:340:20", "--elevation", "30:50:20", "--roll", "-20:20:20", "--light", "0:240:120"];
    let mut synth = vec!["synth", "--object", "cap", "--out", "set"];
    synth.extend(grid);
    d.ok(&synth);
    d.ok(&["train", "--data", "set", "--method", "linear", "--ridge", "1e-3", "--no-normalize", "--out", "m.safetensors"]);
    let out = d.ok(&["eval", "--model", "m.safetensors", "--data", "set", "--json", "e.json"]);
    for name in ["elevation", "azimuth", "roll", "light"] {
        assert!(out.contains(&format!("all {name}")), "{out}");
    }
    let e: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.path("e.json")).unwrap()).unwrap();
    assert_eq!(e["params"], serde_json::json!(["elevation", "azimuth", "roll", "light"]));
    assert_eq!(e["param_all"].as_array().unwrap().len(), 4);
    let space = linpose::PoseSpace::new(vec![
        linpose::Param::linear("elevation"),
        linpose::Param::circular("azimuth", 360.0),
        linpose::Param::linear("roll"),
        linpose::Param::circular("light", 360.0),
    ])
    .unwrap();
    let samples = e["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 18 * 2 * 3 * 3);
    for s in samples {
        let v = |k: &str| s[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect::<Vec<_>>();
        let (t, est) = (v("true"), v("estimated"));
        assert!((s["error_deg"].as_f64().unwrap() - space.error_deg(&t, &est)).abs() < 1e-9);
        assert_eq!(v("param_errors_deg"), space.param_errors_deg(&t, &est));
    }
    // predict gives the four parameters of a view.
    let p: serde_json::Value =
        serde_json::from_str(d.ok(&["predict", "--model", "m.safetensors", "--json", "set/e030.0_a000.0_r-20.0_l000.0.png"]).trim()).unwrap();
    let pose = p["pose"].as_object().unwrap();
    assert_eq!(pose.len(), 4);
    let got = [pose["elevation"].as_f64().unwrap(), pose["azimuth"].as_f64().unwrap(), pose["roll"].as_f64().unwrap(), pose["light"].as_f64().unwrap()];
    // A training view, fitted by the ridge's least squares: near its pose.
    assert!(space.error_deg(&[30.0, 0.0, -20.0, 0.0], &got) < 5.0, "{got:?}");
}
