//! `train`'s memory plan end to end: the path it takes under `--memory-budget`, and the error
//! when no path fits, before any image is read.

mod util;

use util::{write_dataset, Dir};

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A model file's f32 weights.
fn weights(path: &std::path::Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    st.tensor("weights").unwrap().data().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64).collect()
}

/// More images than features (720 > 108): least squares through X^T X, taken by itself within
/// a roomy budget (less memory than the N x N Gram matrix) and within a budget the in-memory fit
/// exceeds (its Gram matrix, about 25 MiB in all; X^T X about 15 MiB); both say why, and write
/// the model the in-memory ridge fit gives (f32 weights, to 1e-6; checked on the same set by
/// `streamed_training_matches_the_in_memory_ridge_fit`). Fewer images than features: in memory.
#[test]
fn train_streams_when_only_streaming_fits_the_budget() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 2, &[20.0, 35.0, 50.0, 65.0], (12, 9)); // 720 images > 108 pixels
    let out = d.run(&["train", "--data", "data", "--ridge", "1e-3", "--memory-budget", "1G", "--out", "roomy.safetensors", "--json", "roomy.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    eprintln!("{err}");
    assert!(err.contains("within the budget of 1.0 GiB; more images than features") && err.contains(": streaming"), "{err}");
    let out = d.run(&["train", "--data", "data", "--ridge", "1e-3", "--memory-budget", "20M", "--out", "st.safetensors", "--json", "st.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    eprintln!("{err}");
    assert!(
        err.contains("(N x N Gram of 720 images), more than the budget of 20.0 MiB; streamed needs ") && err.contains("(X^T X of 108 features): streaming"),
        "{err}"
    );
    assert!(err.contains("least squares / ridge through X^T X"), "the streamed fit says how it fitted: {err}");
    let (roomy, st) = (json(&d.path("roomy.json")), json(&d.path("st.json")));
    assert_eq!((roomy["memory"]["path"].as_str(), st["memory"]["path"].as_str()), (Some("streamed"), Some("streamed")));
    assert_eq!(st["memory"]["limit"], "budget");
    assert!(st["memory"]["estimate_bytes"].as_u64().unwrap() <= 20 << 20 && st["memory"]["in_memory_bytes"].as_u64().unwrap() > 20 << 20, "{}", st["memory"]);
    assert_eq!(weights(&d.path("roomy.safetensors")), weights(&d.path("st.safetensors")));
    // Ridge 0, no flag: the minimum-norm least-squares fit (the Gram matrix would be singular).
    d.ok(&["train", "--data", "data", "--out", "zero.safetensors"]);
    // Fewer images than features: in memory.
    write_dataset(&d.path("few"), 5, &[], (24, 18));
    let out = d.run(&["train", "--data", "few", "--memory-budget", "1G", "--out", "few.safetensors"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.contains("(N x N Gram of 72 images), within the budget of 1.0 GiB: in memory"), "{err}");
}

/// A budget no path fits: a clear error naming the numbers and what would help, a failing exit
/// status, no model file, and all before reading any image but the first's header: every image
/// after the first is corrupt, which a fit that read them would report instead.
#[test]
fn an_impossible_budget_is_refused_before_reading_the_images() {
    let d = Dir::new();
    let data = write_dataset(&d.path("data"), 2, &[20.0, 35.0, 50.0, 65.0], (12, 9));
    let csv = std::fs::read_to_string(data.join("poses.csv")).unwrap();
    let first = csv.lines().nth(1).unwrap().split(',').next().unwrap().to_string();
    for line in csv.lines().skip(2) {
        std::fs::write(data.join(line.split(',').next().unwrap()), b"not a PNG").unwrap();
    }
    for stream in [false, true] {
        let mut args = vec!["train", "--data", "data", "--ridge", "1e-3", "--memory-budget", "4M", "--out", "m.safetensors"];
        if stream {
            args.push("--stream");
        }
        let out = d.run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        eprintln!("{err}");
        assert_eq!(out.status.code(), Some(1), "{err}");
        for part in ["not enough memory to train: ", "(X^T X of 108 features)", "more than the budget of 4.0 MiB", "what would help: ", "--memory-budget "] {
            assert!(err.contains(part), "stream {stream}: lacks '{part}': {err}");
        }
        let needs = if stream { "streamed (as asked) needs " } else { "in memory needs " };
        assert!(err.contains(needs), "{err}");
        assert!(!err.contains("decode") && !err.contains(&first), "no image was read: {err}");
        assert!(!d.path("m.safetensors").exists());
    }
    // The eigenspace (in memory only): the numbers, and fewer or smaller images would help.
    let err = d.fails(
        &["train", "--data", "data", "--method", "eigenspace", "--manifold-step", "5", "--memory-budget", "20M", "--out", "m.safetensors"],
        &["not enough memory", "in memory needs", "the eigenspace method fits in memory only", "more than the budget of 20.0 MiB"],
    );
    assert!(err.contains("fewer training images, at most ") && err.contains("--train-step"), "{err}");
    assert!(!d.path("m.safetensors").exists());
    // With room, the same command reads the images and meets the corrupt ones.
    d.fails(&["train", "--data", "data", "--ridge", "1e-3", "--memory-budget", "1G", "--out", "m.safetensors"], &["not a PNG"]);
    // A budget that is not a size is named.
    let out = d.run(&["train", "--data", "data", "--memory-budget", "8X", "--out", "m.safetensors"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--memory-budget") && err.contains("8X") && err.contains("unknown unit"), "{err}");
}
