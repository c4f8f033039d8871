//! `linpose predict --top / --flag-below / --list`, and the shares of `linpose eval`'s confidence
//! summary, on the duck rendered by `linpose synth` (36 views of 48 x 36) with an eigenspace
//! trained every 20 degrees (which ranks several distinct hypotheses per view).

mod util;

use serde_json::Value;
use std::collections::BTreeMap;
use util::Dir;

/// The duck rendered every 10 degrees at elevation 40, and an eigenspace on every 20 degrees.
fn duck(d: &Dir, train_step: &str) {
    d.ok(&["synth", "--object", "duck", "--azimuth", "0:350:10", "--elevation", "40", "--size", "48x36", "--out", "duck"]);
    d.ok(&["train", "--data", "duck", "--method", "eigenspace", "--train-step", train_step, "--no-normalize", "--out", "m.safetensors"]);
}

/// The JSON lines of a `predict --json`.
fn lines(out: &str) -> Vec<Value> {
    out.lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}"))).collect()
}

fn pose(v: &Value) -> BTreeMap<String, f64> {
    v.as_object().unwrap().iter().map(|(k, x)| (k.clone(), x.as_f64().unwrap())).collect()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn top_gives_ranked_hypotheses_the_first_the_estimate() {
    let d = Dir::new();
    duck(&d, "20");
    let plain = lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "duck"]));
    assert_eq!(plain.len(), 36);
    let top = lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "--top", "3", "duck"]));
    assert_eq!(top.len(), 36);
    let mut three = 0;
    for (p, t) in plain.iter().zip(&top) {
        assert_eq!(p["image"], t["image"]);
        // Without --top: no confidence, flag or hypotheses.
        assert!(p.get("confidence").is_none() && p.get("flagged").is_none() && p.get("hypotheses").is_none(), "{p}");
        let h = t["hypotheses"].as_array().unwrap();
        assert!((1..=3).contains(&h.len()), "{t}");
        three += (h.len() == 3) as usize;
        // The first hypothesis is the estimate printed, and that of the plain predict (the 8-bit
        // path agrees with the features' but for near ties: to a thousandth of a degree).
        assert_eq!(pose(&h[0]["pose"]), pose(&t["pose"]), "{t}");
        for (k, v) in pose(&p["pose"]) {
            assert!((v - pose(&t["pose"])[&k]).abs() < 1e-3, "{k}: {p} vs {t}");
        }
        let scores: Vec<f64> = h.iter().map(|h| f(&h["score"])).collect();
        assert!(scores.iter().all(|s| (0.0..=1.0).contains(s)), "{t}");
        assert!(scores.windows(2).all(|w| w[0] >= w[1]), "scores not by decreasing score: {t}");
        // The estimate's score is its confidence; flagged under the default 0.6.
        let c = f(&t["confidence"]);
        assert_eq!(c, scores[0], "{t}");
        assert_eq!(t["flagged"], c < 0.6, "{t}");
        // Distinct poses.
        for i in 0..h.len() {
            for j in 0..i {
                assert_ne!(pose(&h[i]["pose"]), pose(&h[j]["pose"]), "{t}");
            }
        }
    }
    assert!(three > 0, "no view with 3 hypotheses");
    // --top 1: the estimate alone.
    for t in lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "--top", "1", "duck"])) {
        assert_eq!(t["hypotheses"].as_array().unwrap().len(), 1, "{t}");
    }
    // The text: the confidence, then "#2:", "#3:" for the alternatives the JSON has.
    let text = d.ok(&["predict", "--model", "m.safetensors", "--top", "3", "duck"]);
    assert_eq!(text.lines().count(), 36);
    for (line, t) in text.lines().zip(&top) {
        let n = t["hypotheses"].as_array().unwrap().len();
        assert!(line.starts_with(t["image"].as_str().unwrap()), "{line}");
        assert!(line.contains(&format!("\tconfidence={:.3}", f(&t["confidence"]))), "{line}");
        assert_eq!(line.matches("\t#").count(), n - 1, "{line}");
        assert_eq!(line.contains(&format!("\t#{n}:")), n > 1, "{line}");
    }
    // K is 1 to 8.
    d.fails(&["predict", "--model", "m.safetensors", "--top", "0", "duck"], &["--top"]);
    d.fails(&["predict", "--model", "m.safetensors", "--top", "9", "duck"], &["--top"]);
}

#[test]
fn flag_below_flags_exactly_the_estimates_under_it() {
    let d = Dir::new();
    duck(&d, "40");
    let conf = |below: &str| -> Vec<(f64, bool)> {
        lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "--top", "2", "--flag-below", below, "duck"]))
            .iter()
            .map(|t| (f(&t["confidence"]), t["flagged"].as_bool().unwrap()))
            .collect()
    };
    // 0: nothing is flagged; 1: everything not fully certain.
    let none = conf("0");
    assert!(none.iter().all(|&(c, fl)| (0.0..=1.0).contains(&c) && !fl), "{none:?}");
    let all = conf("1");
    assert!(all.iter().all(|&(c, fl)| fl == (c < 1.0)), "{all:?}");
    // At the median confidence of the views under 1: some flagged, some not, each as its confidence.
    let mut cs: Vec<f64> = none.iter().map(|c| c.0).filter(|&c| c < 1.0).collect();
    cs.sort_by(f64::total_cmp);
    assert!(cs.len() >= 4, "too few uncertain views for the test: {none:?}");
    let mid = cs[cs.len() / 2];
    let at = conf(&mid.to_string());
    let flagged = at.iter().filter(|c| c.1).count();
    assert!(flagged > 0 && flagged < at.len(), "{at:?}");
    assert!(at.iter().all(|&(c, fl)| fl == (c < mid)), "{mid}: {at:?}");
    // The text marks the same views FLAGGED.
    let text = d.ok(&["predict", "--model", "m.safetensors", "--top", "2", "--flag-below", &mid.to_string(), "duck"]);
    let marked: Vec<bool> = text.lines().map(|l| l.contains("\tFLAGGED")).collect();
    assert_eq!(marked, at.iter().map(|c| c.1).collect::<Vec<_>>(), "{text}");
    // A confidence is in [0, 1]; the flag needs --top.
    d.fails(&["predict", "--model", "m.safetensors", "--top", "2", "--flag-below", "1.01", "duck"], &["--flag-below", "outside [0, 1]"]);
    d.fails(&["predict", "--model", "m.safetensors", "--top", "2", "--flag-below=-0.1", "duck"], &["--flag-below -0.1 is outside [0, 1]"]);
    d.fails(&["predict", "--model", "m.safetensors", "--flag-below", "0.5", "duck"], &["--top"]);
}

#[test]
fn list_adds_the_images_it_names_after_those_given() {
    let d = Dir::new();
    duck(&d, "20");
    let names = ["duck/e040.0_a350.0.png", "duck/e040.0_a010.0.png", "duck/e040.0_a200.0.png"];
    // One path a line; blank lines and surrounding spaces ignored.
    std::fs::write(d.path("list.txt"), format!("{}\n\n  {}  \n{}\n", names[0], names[1], names[2])).unwrap();
    let listed = lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "--list", "list.txt"]));
    let got: Vec<&str> = listed.iter().map(|v| v["image"].as_str().unwrap()).collect();
    assert_eq!(got, names);
    // The same estimates as the images given on the command line.
    let direct = lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", names[0], names[1], names[2]]));
    for (a, b) in listed.iter().zip(&direct) {
        assert_eq!(pose(&a["pose"]), pose(&b["pose"]));
    }
    // The azimuth is estimated near the truth (a sanity check of what was read).
    for (v, truth) in listed.iter().zip([350.0, 10.0, 200.0]) {
        let az = pose(&v["pose"])["azimuth"];
        let diff = (az - truth + 540.0f64).rem_euclid(360.0) - 180.0;
        assert!(diff.abs() < 5.0, "{v}");
    }
    // Images given come first, then the list's.
    let both = lines(&d.ok(&["predict", "--model", "m.safetensors", "--json", "--list", "list.txt", "duck/e040.0_a100.0.png"]));
    let got: Vec<&str> = both.iter().map(|v| v["image"].as_str().unwrap()).collect();
    assert_eq!(got, ["duck/e040.0_a100.0.png", names[0], names[1], names[2]]);
    // A list that is not there, or names an image that is not, is an error.
    d.fails(&["predict", "--model", "m.safetensors", "--list", "nope.txt"], &["nope.txt", "cannot read the list"]);
    std::fs::write(d.path("bad.txt"), "duck/e040.0_a999.0.png\n").unwrap();
    d.fails(&["predict", "--model", "m.safetensors", "--list", "bad.txt"], &["e040.0_a999.0.png"]);
    // Neither images nor a list.
    d.fails(&["predict", "--model", "m.safetensors"], &["IMAGE"]);
}

#[test]
fn eval_confidence_shares_are_the_counts_over_the_views() {
    // Trained every 40 degrees and queried with heavy noise, so that some estimates are gross
    // errors and the confidences spread.
    let d = Dir::new();
    duck(&d, "40");
    let mut some_gross = false;
    for below in ["0", "0.3", "0.99", "1"] {
        let out = d.ok(&["eval", "--model", "m.safetensors", "--data", "duck", "--noise", "0.8", "--seed", "1", "--flag-below", below, "--json", "e.json"]);
        let e: Value = serde_json::from_str(&std::fs::read_to_string(d.path("e.json")).unwrap()).unwrap();
        let below: f64 = below.parse().unwrap();
        assert_eq!(f(&e["flag_below"]), below);
        let samples = e["samples"].as_array().unwrap();
        let unseen: Vec<&Value> = samples.iter().filter(|s| s["seen"] == false).collect();
        assert!(!unseen.is_empty());
        let c = &e["confidence"];
        assert_eq!(c["over"], "unseen");
        assert_eq!(c["n"].as_u64().unwrap() as usize, unseen.len());
        for s in &unseen {
            assert_eq!(s["flagged"], f(&s["confidence"]) < below, "{s}");
        }
        let n = unseen.len() as f64;
        let flagged = unseen.iter().filter(|s| s["flagged"] == true).count();
        let gross: Vec<&&Value> = unseen.iter().filter(|s| f(&s["error_deg"]) > 20.0).collect();
        let gross_flagged = gross.iter().filter(|s| s["flagged"] == true).count();
        let in_top = unseen.iter().filter(|s| s["in_top"] == true).count();
        some_gross |= !gross.is_empty();
        assert_eq!(c["flagged"].as_u64().unwrap() as usize, flagged);
        assert_eq!(c["gross"].as_u64().unwrap() as usize, gross.len());
        assert_eq!(c["gross_flagged"].as_u64().unwrap() as usize, gross_flagged);
        let shares = [
            ("flagged_share", flagged as f64 / n),
            ("gross_share", gross.len() as f64 / n),
            ("gross_flagged_share", if gross.is_empty() { 1.0 } else { gross_flagged as f64 / gross.len() as f64 }),
            ("in_top_share", in_top as f64 / n),
        ];
        for (k, want) in shares {
            let got = f(&c[k]);
            assert!((0.0..=1.0).contains(&got) && (got - want).abs() < 1e-12, "{k}: {got} vs {want} (flag below {below})");
        }
        assert_eq!(e["flagged_share"], c["flagged_share"]);
        assert_eq!(e["gross_flagged_share"], c["gross_flagged_share"]);
        // The extremes: nothing is under 0; at 1 every uncertain view is flagged.
        if below == 0.0 {
            assert_eq!(flagged, 0);
        }
        if below == 1.0 {
            assert_eq!(flagged, unseen.iter().filter(|s| f(&s["confidence"]) < 1.0).count());
        }
        // The printed summary gives the same shares.
        let line = out.lines().find(|l| l.starts_with("confidence (")).unwrap_or_else(|| panic!("no confidence line: {out}"));
        let want = format!(
            "confidence (unseen views): {:.1}% flagged (under {below}); {:.1}% gross errors (over 20 degrees), {:.1}% of them flagged; truth among the top 3: {:.1}%",
            100.0 * shares[0].1,
            100.0 * shares[1].1,
            100.0 * shares[2].1,
            100.0 * shares[3].1
        );
        assert_eq!(line, want);
    }
    assert!(some_gross, "no gross error: the shares of gross errors were not tried");
}
