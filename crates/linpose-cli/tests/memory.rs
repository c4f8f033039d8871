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
    // The refined method (in memory only): the numbers, and the budget that would do (its
    // held-out fits' searches, not the images, are what exceed it).
    let err = d.fails(
        &["train", "--data", "data", "--method", "refined", "--memory-budget", "20M", "--out", "m.safetensors"],
        &["not enough memory", "in memory needs", "not streamed: the refined method fits in memory only", "more than the budget of 20.0 MiB"],
    );
    assert!(err.contains("what would help: --memory-budget "), "{err}");
    assert!(!d.path("m.safetensors").exists());
    // With room, the same command reads the images and meets the corrupt ones.
    d.fails(&["train", "--data", "data", "--ridge", "1e-3", "--memory-budget", "1G", "--out", "m.safetensors"], &["not a PNG"]);
    // A budget that is not a size is named.
    let out = d.run(&["train", "--data", "data", "--memory-budget", "8X", "--out", "m.safetensors"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--memory-budget") && err.contains("8X") && err.contains("unknown unit"), "{err}");
}

/// The eigenspace with more images than features streams: three pose parameters rendered at
/// 8 x 6 (108 views > 48 pixels). Asked to stream it reads the images twice (the M x M scatter,
/// then the coordinates), says so, and writes a model without the second look whose poses are
/// the in-memory fit's on every view; the in-memory fit's plan counts its second look, which a
/// budget the streamed fit fits under turns to the streamed path by itself.
#[test]
fn the_eigenspace_streams_from_the_scatter() {
    let d = Dir::new();
    d.ok(&["synth", "--object", "duck", "--out", "data", "--azimuth", "0:330:30", "--elevation", "32:72:20", "--roll", "-20:20:20", "--size", "8x6"]);
    d.ok(&["synth", "--object", "duck", "--out", "queries", "--azimuth", "15:315:60", "--elevation", "42", "--roll", "-10:10:20", "--size", "8x6"]);
    let base = ["train", "--data", "data", "--method", "eigenspace", "--components", "6", "--no-normalize"];
    let train = |extra: &[&str], out: &str| {
        let summary = format!("{out}.json");
        let args: Vec<&str> = base.iter().chain(extra).copied().chain(["--out", out, "--json", &summary]).collect();
        let out = d.run(&args);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{args:?}: {err}");
        err
    };
    let err = train(&["--stream"], "st.safetensors");
    assert!(err.contains("the M x M scatter of 48 features") && err.contains(": streaming"), "{err}");
    assert!(err.contains("two passes over them") && err.contains("no second look"), "{err}");
    let err = train(&[], "mem.safetensors");
    assert!(err.contains("in memory needs") && err.contains("second look") && err.contains(": in memory"), "{err}");
    let (st, mem) = (json(&d.path("st.safetensors.json")), json(&d.path("mem.safetensors.json")));
    assert_eq!((st["memory"]["path"].as_str(), mem["memory"]["path"].as_str()), (Some("streamed"), Some("in memory")));
    assert_eq!(st["settings"]["components"], 6);
    assert!(st["settings"]["second_look"].is_null() && !mem["settings"]["second_look"].is_null());
    // Table 1's terms: N L + M L beside the second look's, which the streamed model lacks.
    assert_eq!(st["storage"]["formula"], mem["storage"]["formula"]);
    assert!(st["storage"]["numbers"].as_u64().unwrap() < mem["storage"]["numbers"].as_u64().unwrap(), "{} {}", st["storage"], mem["storage"]);
    // A budget under the in-memory estimate and over the streamed one: streamed by itself.
    let (in_memory, streamed) = (mem["memory"]["in_memory_bytes"].as_u64().unwrap(), st["memory"]["streamed_bytes"].as_u64().unwrap());
    assert!(streamed < in_memory, "{streamed} {in_memory}");
    let budget = ((streamed + in_memory) / 2).to_string();
    let err = train(&["--memory-budget", &budget], "auto.safetensors");
    assert!(err.contains("; streamed needs ") && err.contains(": streaming"), "{err}");
    // The same poses as the in-memory fit, on the training views and on views between them.
    for data in ["data", "queries"] {
        let poses = |model: &str| {
            let out = format!("{model}.{data}.json");
            d.ok(&["eval", "--model", model, "--data", data, "--json", &out]);
            json(&d.path(&out))["samples"].as_array().unwrap().iter().map(|s| s["pose"].clone()).collect::<Vec<_>>()
        };
        let want = poses("mem.safetensors");
        assert_eq!(poses("st.safetensors"), want, "{data}");
        assert_eq!(poses("auto.safetensors"), want, "{data}");
    }
}
