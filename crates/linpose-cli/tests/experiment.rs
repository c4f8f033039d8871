//! `linpose experiment --quick`: the report's files, and its numbers against a direct
//! evaluation of the same data with the same estimators (the report says what they say).

mod util;

use util::Dir;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn quick_experiment_writes_a_report_that_agrees_with_direct_evaluation() {
    let d = Dir::new();
    let out = d.ok(&["experiment", "--quick", "--objects", "duck", "--open-cases", "twin", "--out", "rep"]);
    assert!(out.contains("Report:") && out.contains("rep/report.html"), "{out}");
    for f in [
        "report.md",
        "report.html",
        "results.json",
        "models/duck-linear.safetensors",
        "models/duck-eigenspace.safetensors",
        "figures/fig2-coefficients-duck.png",
        "figures/fig3-duck-linear.svg",
        "figures/fig3-twin-eigenspace.svg",
        "figures/fig4-duck-linear-noise10.svg",
        "figures/error-cdf.svg",
        "figures/error-vs-training-size.svg",
        "figures/table1-storage-vs-training-views.svg",
    ] {
        assert!(d.path("rep").join(f).is_file(), "missing {f}");
    }
    let md = std::fs::read_to_string(d.path("rep/report.md")).unwrap();
    for s in [
        "What it found",
        "**Accuracy.**",
        "**Storage.**",
        "**Cost.**",
        "**Noise (linear).**",
        "**Overtraining.**",
        "**Open case twin.**",
        "Table 1",
        "NL + ML",
        "MK",
        "**Three pose parameters.**",
        "**Table 1 against N.**",
        "## Three pose parameters: azimuth, elevation and camera roll",
        "### Table 1 against the number of training views",
    ] {
        assert!(md.contains(s), "report.md lacks {s}");
    }
    let html = std::fs::read_to_string(d.path("rep/report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("data:image/png;base64,"), "figures are inline");
    // Only the SVG namespace URI may appear: nothing is fetched (no src/href to a file or host).
    assert!(
        !html.contains("src=\"figures/") && !html.contains("src=\"http") && !html.contains("href=\"http") && !html.contains("@import"),
        "the page needs no other file and no network"
    );

    // The same data, made and evaluated directly through the CLI (the study fits each method on
    // the images as given, as the paper did: no normalisation stage).
    d.ok(&["synth", "--object", "duck", "--azimuth", "0:351:9", "--elevation", "32:77:9", "--size", "80x60", "--out", "duck"]);
    let r = json(&d.path("rep/results.json"));
    let duck = r["objects"].as_array().unwrap().iter().find(|o| o["name"] == "duck").unwrap();
    for method in ["linear", "eigenspace"] {
        d.ok(&["train", "--data", "duck", "--train-step", "18", "--method", method, "--no-normalize", "--out", &format!("{method}.safetensors")]);
        for (noise, seed) in [("0", "0"), ("0.1", "0")] {
            let file = format!("{method}-{noise}.json");
            d.ok(&["eval", "--model", &format!("{method}.safetensors"), "--data", "duck", "--noise", noise, "--seed", seed, "--json", &file]);
            let e = json(&d.path(&file));
            let run = duck["runs"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["method"] == method && x["noise"].as_f64().unwrap() == noise.parse::<f64>().unwrap())
                .unwrap();
            assert_eq!(run["n_train"], e["n_train"]);
            assert_eq!(run["model_bytes"], e["model_bytes"]);
            for stat in ["mean_deg", "median_deg", "p90_deg", "max_deg"] {
                let (a, b) = (run["unseen"][stat].as_f64().unwrap(), e["unseen"][stat].as_f64().unwrap());
                assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "{method} noise {noise} {stat}: report {a} vs direct {b}");
            }
        }
        // The model the report saved estimates as the one trained here.
        d.ok(&["eval", "--model", &format!("rep/models/duck-{method}.safetensors"), "--data", "duck", "--json", "saved.json"]);
        let (saved, direct) = (json(&d.path("saved.json")), json(&d.path(&format!("{method}-0.json"))));
        assert_eq!(saved["samples"], direct["samples"]);
    }
    // Table 1's bytes are the models' own.
    let t1 = duck["table1"].as_array().unwrap();
    let lin = t1.iter().find(|t| t["method"] == "linear").unwrap();
    assert_eq!(lin["formula_numbers"], 80 * 60 * 3);
    three_params_agree_with_direct_evaluation(&d, &r, &md);
}

/// The three-parameter section of the report in `d/rep` (`results`, `md`) against the same
/// grid rendered, trained and evaluated through the CLI.
fn three_params_agree_with_direct_evaluation(d: &Dir, results: &serde_json::Value, md: &str) {
    let t = &results["study"]["three_params"];
    assert_eq!(t["object"], "duck");
    assert_eq!(t["params"], serde_json::json!(["elevation", "azimuth", "roll"]));
    d.ok(&["synth", "--object", "duck", "--azimuth", "0:348:12", "--elevation", "32:68:9", "--roll", "-30:30:15", "--size", "80x60", "--out", "three"]);
    // The every-other-value lattice: azimuth every 24, elevation 32, 50, 68, roll -30, 0, 30.
    let poses = std::fs::read_to_string(d.path("three/poses.csv")).unwrap();
    let train: Vec<&str> = poses
        .lines()
        .skip(1)
        .filter(|l| {
            let c: Vec<f64> = l.split(',').skip(1).map(|v| v.parse().unwrap()).collect();
            [32.0, 50.0, 68.0].contains(&c[0]) && c[1] % 24.0 == 0.0 && [-30.0, 0.0, 30.0].contains(&c[2])
        })
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!((t["n_views"].as_u64().unwrap(), t["n_train"].as_u64().unwrap(), t["n_unseen"].as_u64().unwrap()), (750, 135, 615));
    assert_eq!(train.len(), 135);
    std::fs::write(d.path("train.txt"), train.join("\n")).unwrap();
    let rows = t["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3, "every method");
    for row in rows {
        let method = row["method"].as_str().unwrap();
        let model = format!("three-{method}.safetensors");
        d.ok(&["train", "--data", "three", "--train-list", "train.txt", "--method", method, "--no-normalize", "--out", &model]);
        let file = format!("three-{method}.json");
        d.ok(&["eval", "--model", &model, "--data", "three", "--json", &file]);
        let e = json(&d.path(&file));
        assert_eq!(row["model_bytes"], e["model_bytes"], "{method}");
        // Every view off the lattice is inside the training range here.
        let unseen: Vec<&serde_json::Value> = e["samples"].as_array().unwrap().iter().filter(|s| s["seen"] == false).collect();
        assert_eq!(unseen.len(), 615);
        let err = |s: &&serde_json::Value| s["error_deg"].as_f64().unwrap();
        let mean = unseen.iter().map(err).sum::<f64>() / unseen.len() as f64;
        let reported = row["unseen"]["mean_deg"].as_f64().unwrap();
        assert!((mean - reported).abs() <= 1e-9 * mean.max(1.0), "{method}: report {reported} vs direct {mean}");
        let gross = unseen.iter().filter(|s| err(s) > 20.0).count() as u64;
        let gross_flagged = unseen.iter().filter(|s| err(s) > 20.0 && s["flagged"] == true).count() as u64;
        assert_eq!((row["gross"].as_u64().unwrap(), row["gross_flagged"].as_u64().unwrap()), (gross, gross_flagged), "{method}");
        let bytes = row["model_bytes"].as_u64().unwrap();
        assert!(md.contains(&format!("| {method} | {bytes} |")), "the section's table has the {method} row");
    }
    let linear = rows.iter().find(|r| r["method"] == "linear").unwrap();
    assert_eq!(linear["formula_numbers"], 80 * 60 * 4, "M K with K = 4: (cos, sin) azimuth, elevation, roll");
    // The Table 1 figure has every method with one, two and three parameters, the linear
    // model's storage the same M K at every N.
    let sizes = results["study"]["table1_sizes"].as_array().unwrap();
    for method in ["linear", "eigenspace", "refined"] {
        for (k, params) in [(2, 1), (3, 2), (4, 3)] {
            let pts: Vec<&serde_json::Value> = sizes.iter().filter(|p| p["method"] == method && p["params"] == params).collect();
            assert!(pts.len() >= 2, "{method} with {params} parameters: {} points", pts.len());
            if method == "linear" {
                assert!(pts.iter().all(|p| p["formula_numbers"] == 80 * 60 * k), "{method} with {params} parameters");
            }
        }
    }
}

#[test]
fn experiment_refuses_bad_arguments_before_any_work() {
    let d = Dir::new();
    d.fails(&["experiment", "--quick", "--objects", "teapot", "--out", "rep"], &["teapot"]);
    d.fails(&["experiment", "--quick", "--noise", "2", "--out", "rep"], &["noise", "[0, 1]"]);
    d.fails(&["experiment", "--quick", "--full", "--out", "rep"], &["--full", "--quick"]);
    std::fs::write(d.path("file"), "x").unwrap();
    d.fails(&["experiment", "--quick", "--out", "file"], &["file", "not a folder"]);
    assert!(!d.path("rep").exists());
}

#[test]
fn quick_experiment_reports_every_runs_confidence() {
    let d = Dir::new();
    d.ok(&["experiment", "--quick", "--objects", "duck", "--open-cases", "twin", "--noise", "0,0.1", "--size-steps", "36", "--out", "rep"]);
    assert!(d.path("rep/figures/confidence-vs-error.svg").is_file(), "the confidence figure is written");
    let md = std::fs::read_to_string(d.path("rep/report.md")).unwrap();
    for s in
        ["## Confidence: does each estimate say when it is unsure?", "**Confidence.**", "**Confidence on the open cases.**", "figures/confidence-vs-error.svg"]
    {
        assert!(md.contains(s), "report.md lacks {s}");
    }
    assert!(!md.contains("NaN") && !md.contains("inf%"), "no number is written as NaN or inf");
    // One table row per run with a confidence, its gross errors flagged as results.json says.
    let r = json(&d.path("rep/results.json"));
    let mut runs = 0;
    for o in r["objects"].as_array().unwrap() {
        for run in o["runs"].as_array().unwrap() {
            let Some(c) = run.get("confidence").filter(|c| !c.is_null()) else { continue };
            runs += 1;
            let noise =
                if run["noise"].as_f64().unwrap() == 0.0 { "clean".to_string() } else { format!("+-{}%", (run["noise"].as_f64().unwrap() * 100.0).round()) };
            let start = format!("| {} | {noise} | {} | ", o["name"].as_str().unwrap(), run["method"].as_str().unwrap());
            let row = md.lines().find(|l| l.starts_with(&start)).unwrap_or_else(|| panic!("no confidence row {start}"));
            let cells: Vec<&str> = row.trim_matches('|').split(" | ").map(str::trim).collect();
            let gross = (c["gross_share"].as_f64().unwrap() * c["n"].as_f64().unwrap()).round();
            if gross == 0.0 {
                assert_eq!(cells[6], "none", "{row}");
            } else {
                assert!(cells[6].starts_with(&format!("{:.1}%", 100.0 * c["gross_flagged_share"].as_f64().unwrap())), "{row}");
            }
        }
    }
    assert!(runs >= 4, "every method has a confidence on both objects");
}

/// `experiment --quick` on the duck alone, untimed, with `threads` threads, into `d/out`.
fn untimed_quick_duck(d: &Dir, out: &str, threads: usize) {
    let args = ["experiment", "--quick", "--objects", "duck", "--open-cases", "", "--noise", "0", "--size-steps", "36", "--no-timings", "--out", out];
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linpose"))
        .args(args)
        .current_dir(d.path(""))
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .unwrap();
    assert!(o.status.success(), "linpose {args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn quick_experiment_reports_scenes_plain_and_robust() {
    let d = Dir::new();
    untimed_quick_duck(&d, "a", 1);
    untimed_quick_duck(&d, "b", 2);
    // Untimed, the report is the same bytes with one thread or two, the scenes section's included.
    for f in ["results.json", "report.md", "figures/scenes-error-vs-hidden.svg"] {
        assert!(std::fs::read(d.path("a").join(f)).unwrap() == std::fs::read(d.path("b").join(f)).unwrap(), "{f} differs with 1 and 2 threads");
    }
    let md = std::fs::read_to_string(d.path("a/report.md")).unwrap();
    for s in ["## Scenes: clutter and occluders", "### What the robust stage costs", "**Scenes.**", "figures/scenes-error-vs-hidden.svg"] {
        assert!(md.contains(s), "report.md lacks {s}");
    }
    let r = json(&d.path("a/results.json"));
    let s = &r["study"]["scenes"];
    let rows = s["rows"].as_array().unwrap();
    // Texture at 0, 10, ..., 50% hidden; the studio backdrop and noise at 0 and 20%; each method.
    assert_eq!(rows.len(), 10 * 3, "one row per condition and method");
    let row = |backdrop: &str, occlude: f64, method: &str| {
        rows.iter().find(|x| x["backdrop"] == backdrop && x["occlude"].as_f64().unwrap() == occlude && x["method"] == method).unwrap()
    };
    for method in ["linear", "eigenspace", "refined"] {
        for (backdrop, occlude) in [("studio", 0.0), ("studio", 0.2), ("texture", 0.0), ("texture", 0.2), ("texture", 0.5), ("noise", 0.2)] {
            let x = row(backdrop, occlude, method);
            assert_eq!(x["n_unseen"], 16, "{backdrop} {occlude} {method}");
            assert!((x["hidden"].as_f64().unwrap() - occlude).abs() < 0.03, "{backdrop} {occlude}: hidden {}", x["hidden"]);
            let cells = format!("| {backdrop} | {:.0}% | {:.1}% | {method} | ", 100.0 * occlude, 100.0 * x["hidden"].as_f64().unwrap());
            assert!(md.contains(&cells), "the table has the row {cells}");
        }
        // Studio views pass the stage's check: the same answers.
        let studio = row("studio", 0.0, method);
        assert_eq!(studio["plain"], studio["robust"], "{method} on studio views");
        // Over clutter with a fifth hidden, the stage repairs the views: far better than plain.
        let x = row("texture", 0.2, method);
        let (plain, robust) = (x["plain"]["mean_deg"].as_f64().unwrap(), x["robust"]["mean_deg"].as_f64().unwrap());
        assert!(plain > 30.0 && robust < 0.5 * plain, "{method}, texture 20%: plain {plain:.1} degrees, robust {robust:.1}");
        assert!(x["robust"]["gross"].as_u64().unwrap() < x["plain"]["gross"].as_u64().unwrap(), "{method}: gross errors");
        assert_eq!(x["plain"]["per_query_us"], 0.0, "untimed");
    }
    let stages = s["stages"].as_array().unwrap();
    assert_eq!(stages.len(), 1);
    // The same views and models through the CLI: the report's robust eigenspace (its stage
    // shared with the other methods) is what `train --robust` gives.
    d.ok(&["synth", "--object", "duck", "--azimuth", "0:351:9", "--elevation", "32:77:9", "--size", "80x60", "--out", "duck"]);
    d.ok(&[
        "synth",
        "--object",
        "duck",
        "--azimuth",
        "6:342:48",
        "--elevation",
        "35:59:24",
        "--size",
        "80x60",
        "--background",
        "texture",
        "--occlude",
        "0.2",
        "--out",
        "tex20",
    ]);
    d.ok(&["train", "--data", "duck", "--train-step", "18", "--method", "eigenspace", "--no-normalize", "--robust", "--out", "robust.safetensors"]);
    d.ok(&["eval", "--model", "robust.safetensors", "--data", "tex20", "--json", "tex20.json"]);
    let e = json(&d.path("tex20.json"));
    let x = row("texture", 0.2, "eigenspace");
    let (a, b) = (x["robust"]["mean_deg"].as_f64().unwrap(), e["unseen"]["mean_deg"].as_f64().unwrap());
    assert!((a - b).abs() <= 1e-9 * a.max(1.0), "report {a} vs direct {b}");
    let model_bytes = std::fs::metadata(d.path("robust.safetensors")).unwrap().len();
    assert!(model_bytes as f64 > stages[0]["stage_bytes"].as_f64().unwrap(), "the model file holds the stage");
}
