//! `train --shard I/N --partial FILE` and `merge`: the merged model is the single-process model,
//! and partials that do not belong together are refused by name.

mod util;

use util::{write_dataset, Dir};

/// Every tensor of a model file, as f64, by name.
fn tensors(d: &Dir, file: &str) -> Vec<(String, Vec<f64>)> {
    let bytes = std::fs::read(d.path(file)).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let mut out: Vec<(String, Vec<f64>)> = st
        .tensors()
        .into_iter()
        .map(|(name, t)| {
            let v = match t.dtype() {
                safetensors::Dtype::F32 => t.data().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64).collect(),
                _ => t.data().chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect(),
            };
            (name, v)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The largest relative difference of two model files' tensors (each tensor's norm).
fn largest_difference(d: &Dir, a: &str, b: &str) -> f64 {
    let (x, y) = (tensors(d, a), tensors(d, b));
    assert_eq!(x.iter().map(|t| &t.0).collect::<Vec<_>>(), y.iter().map(|t| &t.0).collect::<Vec<_>>());
    x.iter()
        .zip(&y)
        .map(|((_, p), (_, q))| {
            let num: f64 = p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            let den: f64 = p.iter().map(|a| a * a).sum::<f64>().max(1e-300);
            (num / den).sqrt()
        })
        .fold(0.0, f64::max)
}

fn shards_then_merge(d: &Dir, data: &str, count: usize, extra: &[&str], out: &str) -> String {
    let mut parts = Vec::new();
    for i in 1..=count {
        let part = format!("{out}.{i}.partial");
        let shard = format!("{i}/{count}");
        let mut args = vec!["train", "--data", data, "--shard", &shard, "--partial", &part];
        args.extend(extra);
        let r = d.run(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        assert!(String::from_utf8_lossy(&r.stderr).contains(&format!("shard {i}/{count}")));
        parts.push(part);
    }
    parts.reverse(); // any order
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(String::as_str));
    args.extend(["--out", out]);
    let r = d.run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    String::from_utf8_lossy(&r.stderr).into_owned()
}

/// More images than pixels (shards of images) and fewer (shards of pixels), for the linear model
/// and the eigenspace: the merged model file is the single process's, to f32 rounding of the
/// same f64 model (the f64 models agree to 1e-9; the library's tests check that).
#[test]
fn merged_shards_give_the_single_process_model() {
    let d = Dir::new();
    write_dataset(&d.path("many"), 2, &[20.0, 35.0, 50.0, 65.0], (12, 9)); // 720 images > 108 pixels
    write_dataset(&d.path("few"), 5, &[], (24, 18)); // 72 images < 432 pixels
    d.ok(&["train", "--data", "many", "--stream", "--ridge", "1e-3", "--out", "many.single"]);
    let said = shards_then_merge(&d, "many", 3, &["--ridge", "1e-3"], "many.merged");
    assert!(said.contains("merged 3 partial statistics") && said.contains("720 images"), "{said}");
    d.ok(&["train", "--data", "few", "--out", "few.single"]);
    shards_then_merge(&d, "few", 4, &[], "few.merged");
    d.ok(&["train", "--data", "few", "--method", "eigenspace", "--components", "8", "--out", "eig.single"]);
    shards_then_merge(&d, "few", 2, &["--method", "eigenspace", "--components", "8"], "eig.merged");
    for (a, b) in [("many.single", "many.merged"), ("few.single", "few.merged"), ("eig.single", "eig.merged")] {
        let r = largest_difference(&d, a, b);
        eprintln!("{b}: largest relative difference of a tensor {r:.2e}");
        assert!(r < 1e-6, "{b}: {r:e}");
    }
    // And they estimate the same poses.
    let eval = |m: &str| d.ok(&["eval", "--model", m, "--data", "few", "--json", &format!("{m}.json")]);
    eval("eig.single");
    eval("eig.merged");
    let mean = |m: &str| -> f64 {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.path(&format!("{m}.json"))).unwrap()).unwrap();
        v["all"]["mean_deg"].as_f64().unwrap()
    };
    assert!((mean("eig.single") - mean("eig.merged")).abs() < 1e-6);
}

#[test]
fn partials_that_do_not_belong_together_are_refused() {
    let d = Dir::new();
    write_dataset(&d.path("a"), 5, &[], (24, 18));
    write_dataset(&d.path("b"), 5, &[], (20, 15));
    d.ok(&["train", "--data", "a", "--shard", "1/2", "--partial", "a1"]);
    d.ok(&["train", "--data", "a", "--shard", "2/2", "--partial", "a2"]);
    d.ok(&["train", "--data", "b", "--shard", "2/2", "--partial", "b2"]);
    d.ok(&["train", "--data", "a", "--shard", "2/2", "--partial", "r2", "--ridge", "1e-3"]);
    d.ok(&["train", "--data", "a", "--shard", "2/2", "--partial", "e2", "--method", "eigenspace"]);
    d.fails(&["merge", "a1", "b2", "--out", "m"], &["b2", "image size 24x18", "20x15"]);
    d.fails(&["merge", "a1", "r2", "--out", "m"], &["r2", "settings", "ridge=1e-3"]);
    d.fails(&["merge", "a1", "e2", "--out", "m"], &["method linear here, eigenspace there"]);
    d.fails(&["merge", "a1", "a1", "--out", "m"], &["both hold pixels 0..216", "the same shard twice"]);
    d.fails(&["merge", "a2", "--out", "m"], &["missing pixels 0..216 of 432"]);
    assert!(!d.path("m").exists(), "no model is written when merging fails");
    // A model file is not a partial, and a partial is not a model.
    d.ok(&["merge", "a1", "a2", "--out", "m"]);
    d.fails(&["merge", "m", "--out", "m2"], &["m: not a file of partial training statistics"]);
    d.fails(&["eval", "--model", "a1", "--data", "a"], &["a1", "partial training statistics", "linpose merge"]);
    // Shard arguments.
    d.fails(&["train", "--data", "a", "--shard", "0/2", "--partial", "x"], &["'0/2'", "I/N"]);
    d.fails(&["train", "--data", "a", "--shard", "3/2", "--partial", "x"], &["'3/2'"]);
    d.fails(&["train", "--data", "a", "--shard", "1/2"], &["--partial"]);
    d.fails(&["train", "--data", "a", "--shard", "1/500", "--partial", "x"], &["more shards than the 432 pixels"]);
    d.fails(&["train", "--data", "a", "--shard", "1/2", "--partial", "x", "--method", "refined"], &["refined", "one process"]);
    assert!(!d.path("x").exists());
}

/// Two objects rendered on one grid have the same image names and poses: their shards are
/// refused by `merge`, naming both files and the images; shards of one object still merge into
/// the single-process model.
#[test]
fn shards_of_two_data_sets_with_one_manifest_are_refused() {
    let d = Dir::new();
    for o in ["duck", "cap"] {
        d.ok(&["synth", "--object", o, "--azimuth", "0:350:10", "--elevation", "40", "--size", "20x15", "--out", o]);
    }
    d.ok(&["train", "--data", "duck", "--shard", "1/2", "--partial", "d1", "--ridge", "1e-3"]);
    d.ok(&["train", "--data", "cap", "--shard", "2/2", "--partial", "c2", "--ridge", "1e-3"]);
    d.fails(&["merge", "d1", "c2", "--out", "m"], &["d1", "c2", "training images", "the same names and poses"]);
    assert!(!d.path("m").exists());
    d.ok(&["train", "--data", "duck", "--shard", "2/2", "--partial", "d2", "--ridge", "1e-3"]);
    d.ok(&["merge", "d1", "d2", "--out", "m"]);
    d.ok(&["train", "--data", "duck", "--ridge", "1e-3", "--no-normalize", "--out", "whole"]);
    assert!(largest_difference(&d, "m", "whole") <= 1e-9);
}
