//! What linpose writes is never half-written, and the same command writes the same bytes.
//!
//! - Killed with SIGKILL at any moment, `train`, `merge`, `predict --out`, `synth` and
//!   `experiment` leave at their output path either what was there before (or nothing) or the
//!   complete new output; never a partial file or folder. Their temporary `.NAME.tmp-PID`
//!   leftovers are hidden names, and the next successful write removes them.
//! - The same command run twice, with 1 or 2 threads, writes byte-identical models and reports.
//!   Reports hold timings: `train --json` and `eval --json` have them under keys ending in `_s`,
//!   which the comparison sets to 0; `experiment --no-timings` writes 0 for them itself.

mod util;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use util::{write_dataset, Dir};

fn linpose(dir: &Path, args: &[&str], threads: usize) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_linpose"));
    c.args(args).current_dir(dir).env("RAYON_NUM_THREADS", threads.to_string()).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

/// Runs to completion, asserting success; returns the wall time.
fn complete(dir: &Path, args: &[&str], threads: usize) -> Duration {
    let t = Instant::now();
    let out = linpose(dir, args, threads).output().unwrap();
    assert!(out.status.success(), "linpose {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    t.elapsed()
}

/// Starts the command and kills it with SIGKILL after `delay` (or lets it finish first).
fn kill_after(dir: &Path, args: &[&str], delay: Duration) {
    let mut child = linpose(dir, args, 2).stderr(Stdio::null()).spawn().unwrap();
    std::thread::sleep(delay);
    let _ = child.kill(); // SIGKILL on Unix
    let _ = child.wait();
}

/// `n` delays spread over `full` (the time a complete run takes), from the very start to just
/// after the end.
fn delays(full: Duration, n: u32) -> impl Iterator<Item = Duration> {
    (0..n).map(move |i| full.mul_f64(i as f64 / (n - 1) as f64 * 1.1))
}

/// Kills `args` (which writes `file`) at ten moments spread over `full`, each time with `old` at
/// `file` first: after each kill `file` holds `old` or `new`, never a part.
fn kills_keep_old_or_new(dir: &Path, args: &[&str], file: &str, full: Duration, old: &[u8], new: &[u8]) {
    for delay in delays(full, 10) {
        std::fs::write(dir.join(file), old).unwrap();
        kill_after(dir, args, delay);
        let now = std::fs::read(dir.join(file)).unwrap();
        assert!(now == old || now == new, "killed after {delay:?}: {file} is neither the old nor the new one ({} bytes)", now.len());
    }
}

fn hidden_leftovers(dir: &Path, name: &str) -> Vec<String> {
    std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|f| f.starts_with(&format!(".{name}."))).collect()
}

#[test]
fn killed_train_leaves_the_old_model_or_the_new_one() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 5, &[20.0, 40.0], (48, 36));
    let new_args = ["train", "--data", "data", "--method", "eigenspace", "--manifold-step", "0.5", "--out", "m.safetensors"];
    let full = complete(&d.path(""), &new_args, 2);
    eprintln!("train runs {full:?}");
    let new = std::fs::read(d.path("m.safetensors")).unwrap();
    complete(&d.path(""), &["train", "--data", "data", "--out", "m.safetensors"], 2);
    let old = std::fs::read(d.path("m.safetensors")).unwrap();
    assert_ne!(old, new);
    kills_keep_old_or_new(&d.path(""), &new_args, "m.safetensors", full, &old, &new);
    // A complete run removes what the killed ones left.
    complete(&d.path(""), &new_args, 2);
    assert_eq!(std::fs::read(d.path("m.safetensors")).unwrap(), new);
    assert_eq!(hidden_leftovers(&d.path(""), "m.safetensors"), Vec::<String>::new());
}

#[test]
fn killed_merge_leaves_the_old_model_or_the_new_one() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 2, &[20.0, 40.0], (48, 36));
    for i in 1..=2 {
        complete(&d.path(""), &["train", "--data", "data", "--ridge", "1e-3", "--shard", &format!("{i}/2"), "--partial", &format!("p{i}")], 2);
    }
    let new_args = ["merge", "p1", "p2", "--out", "m.safetensors"];
    let full = complete(&d.path(""), &new_args, 2);
    eprintln!("merge runs {full:?}");
    let new = std::fs::read(d.path("m.safetensors")).unwrap();
    complete(&d.path(""), &["train", "--data", "data", "--out", "m.safetensors"], 2);
    let old = std::fs::read(d.path("m.safetensors")).unwrap();
    assert_ne!(old, new);
    kills_keep_old_or_new(&d.path(""), &new_args, "m.safetensors", full, &old, &new);
    complete(&d.path(""), &new_args, 2);
    assert_eq!(std::fs::read(d.path("m.safetensors")).unwrap(), new);
    assert_eq!(hidden_leftovers(&d.path(""), "m.safetensors"), Vec::<String>::new());
}

#[test]
fn killed_predict_out_leaves_the_old_estimates_or_the_new_ones() {
    let d = Dir::new();
    complete(&d.path(""), &["synth", "--object", "duck", "--azimuth", "0:359:1", "--elevation", "30:60:10", "--size", "48x36", "--out", "set"], 2);
    complete(&d.path(""), &["train", "--data", "set", "--method", "eigenspace", "--train-step", "10", "--out", "m.safetensors"], 2);
    let new_args = ["predict", "--model", "m.safetensors", "--json", "--top", "3", "--out", "p.jsonl", "set"];
    let full = complete(&d.path(""), &new_args, 2);
    eprintln!("predict runs {full:?}");
    let new = std::fs::read(d.path("p.jsonl")).unwrap();
    assert_eq!(String::from_utf8_lossy(&new).lines().count(), 1440);
    let old = b"the previous estimates\n".to_vec();
    kills_keep_old_or_new(&d.path(""), &new_args, "p.jsonl", full, &old, &new);
    // --strict stopped by a bad image: the old file stays, nothing else is left.
    std::fs::write(d.path("p.jsonl"), &old).unwrap();
    image::GrayImage::new(48, 36).save(d.path("black.png")).unwrap();
    let out = linpose(&d.path(""), &["predict", "--model", "m.safetensors", "--strict", "--out", "p.jsonl", "set/e030.0_a000.0.png", "black.png"], 2)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(d.path("p.jsonl")).unwrap(), old);
    complete(&d.path(""), &new_args, 2);
    assert_eq!(hidden_leftovers(&d.path(""), "p.jsonl"), Vec::<String>::new());
}

/// An output folder that cannot be written in: a clear error naming the file, exit status 1,
/// and nothing left behind. A read-only folder, or where the test runs as root (who writes in
/// one anyway) a folder of /proc, where nobody creates files.
#[test]
fn an_unwritable_output_folder_is_an_error_and_leaves_nothing() {
    use std::os::unix::fs::PermissionsExt;
    let d = Dir::new();
    write_dataset(&d.path("data"), 10, &[], (24, 18));
    std::fs::create_dir(d.path("ro")).unwrap();
    std::fs::set_permissions(d.path("ro"), std::fs::Permissions::from_mode(0o555)).unwrap();
    let ro = if std::fs::write(d.path("ro/probe"), b"x").is_ok() { "/proc/self".to_string() } else { d.path("ro").display().to_string() };
    for args in [
        vec!["train".to_string(), "--data".into(), "data".into(), "--out".into(), format!("{ro}/m.safetensors")],
        vec!["train".to_string(), "--data".into(), "data".into(), "--shard".into(), "1/2".into(), "--partial".into(), format!("{ro}/p1")],
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = linpose(&d.path(""), &args, 2).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(&format!("{ro}/")) && stderr.contains("linpose: error:"), "{args:?}: {stderr}");
    }
    let _ = std::fs::remove_file(d.path("ro/probe"));
    assert_eq!(std::fs::read_dir(d.path("ro")).unwrap().count(), 0);
}

/// A disk that fills up while the model is written (a file size limit, `ulimit -f`, with the
/// signal it raises ignored, so writes fail as on a full disk): a clear error naming the file,
/// exit status 1, the previous model intact and no temporary file left.
#[test]
fn a_full_disk_while_writing_is_an_error_and_keeps_the_old_model() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 5, &[20.0, 40.0], (48, 36));
    complete(&d.path(""), &["train", "--data", "data", "--out", "m.safetensors"], 2);
    let old = std::fs::read(d.path("m.safetensors")).unwrap();
    let exe = env!("CARGO_BIN_EXE_linpose");
    // 64 blocks: far less than the eigenspace model's file.
    let script = format!("ulimit -f 64 && trap '' XFSZ && exec '{exe}' train --data data --method eigenspace --out m.safetensors");
    let out = Command::new("sh").arg("-c").arg(&script).current_dir(d.path("")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("linpose: error:") && stderr.contains("m.safetensors"), "{stderr}");
    assert_eq!(std::fs::read(d.path("m.safetensors")).unwrap(), old);
    assert_eq!(hidden_leftovers(&d.path(""), "m.safetensors"), Vec::<String>::new());
}

#[test]
fn killed_synth_leaves_no_data_set_or_a_complete_one() {
    let d = Dir::new();
    let args = ["synth", "--object", "duck", "--out", "set", "--azimuth", "0:350:10", "--elevation", "30:60:15", "--size", "48x36"];
    let full = complete(&d.path(""), &args, 2);
    eprintln!("synth runs {full:?}");
    let csv = std::fs::read_to_string(d.path("set/poses.csv")).unwrap();
    let complete_set = |dir: &Path| -> bool {
        std::fs::read_to_string(dir.join("poses.csv")).is_ok_and(|c| c == csv)
            && csv.lines().skip(1).all(|l| image::open(dir.join(l.split(',').next().unwrap())).is_ok())
    };
    for delay in delays(full, 8) {
        let _ = std::fs::remove_dir_all(d.path("set"));
        kill_after(&d.path(""), &args, delay);
        let set = d.path("set");
        assert!(!set.exists() || complete_set(&set), "killed after {delay:?}: a partial data set at set/");
    }
    let _ = std::fs::remove_dir_all(d.path("set"));
    complete(&d.path(""), &args, 2);
    assert!(complete_set(&d.path("set")));
    assert_eq!(hidden_leftovers(&d.path(""), "set"), Vec::<String>::new());
}

#[test]
fn killed_experiment_leaves_the_old_report_or_the_new_one() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 10, &[], (32, 24));
    let study = |seed: &'static str| {
        ["experiment", "--data", "data", "--train-step", "20", "--size-steps", "20,40", "--noise", "0,0.05", "--seed", seed, "--no-timings", "--out", "r"]
    };
    complete(&d.path(""), &study("1"), 2);
    let old = std::fs::read(d.path("r/results.json")).unwrap();
    let full = complete(&d.path(""), &study("2"), 2);
    eprintln!("experiment runs {full:?}");
    let new = std::fs::read(d.path("r/results.json")).unwrap();
    assert_ne!(old, new);
    // One model per method the study compares, as a complete run writes them.
    let n_models = std::fs::read_dir(d.path("r/models")).unwrap().count();
    assert!(n_models >= 2);
    let whole = |r: &Path| -> Option<Vec<u8>> {
        let json = std::fs::read(r.join("results.json")).ok()?;
        let md = std::fs::read_to_string(r.join("report.md")).ok()?;
        let models = std::fs::read_dir(r.join("models")).ok()?.count();
        (r.join("report.html").is_file() && md.contains("Table 1") && models == n_models).then_some(json)
    };
    complete(&d.path(""), &study("1"), 2);
    let old_tree = tree(&d.path("r"));
    for delay in delays(full, 6) {
        let _ = std::fs::remove_dir_all(d.path("r"));
        for (f, bytes) in &old_tree {
            let p = d.path("r").join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, bytes).unwrap();
        }
        kill_after(&d.path(""), &study("2"), delay);
        // Replacing a folder takes two renames (old aside, new in): killed between them, the
        // report is absent, never partial.
        let r = d.path("r");
        let now = whole(&r);
        assert!(
            !r.exists() || now.as_ref() == Some(&old) || now.as_ref() == Some(&new),
            "killed after {delay:?}: the report is neither the old nor the new one"
        );
    }
    complete(&d.path(""), &study("2"), 2);
    assert_eq!(hidden_leftovers(&d.path(""), "r"), Vec::<String>::new());
}

/// A JSON report with every timing (a key ending in `_s`) set to 0 and the memory plan reduced
/// to its path.
fn untimed(path: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            // The memory plan's figures depend on the machine (its available memory, its
            // threads) as the timings do: its path is compared, not its bytes.
            serde_json::Value::Object(m) => m.iter_mut().for_each(|(k, v)| match k.as_str() {
                k if k.ends_with("_s") => *v = 0.into(),
                "memory" => *v = v["path"].clone(),
                _ => strip(v),
            }),
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    strip(&mut v);
    v
}

/// Every file under `dir`, by relative path, with its bytes.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).unwrap() {
            let e = e.unwrap().path();
            if e.is_dir() {
                stack.push(e);
            } else {
                out.push((e.strip_prefix(dir).unwrap().display().to_string(), std::fs::read(&e).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn same_command_same_bytes_with_one_or_two_threads() {
    let d = Dir::new();
    write_dataset(&d.path("data"), 10, &[20.0, 35.0, 50.0], (40, 30));
    let root = d.path("");
    for (run, threads) in [("a", 1), ("b", 2), ("c", 2)] {
        let m = |s: &str| format!("{run}-{s}");
        let (lin, eig) = (m("linear.safetensors"), m("eigen.safetensors"));
        complete(&root, &["train", "--data", "data", "--train-step", "20", "--out", &lin, "--json", &m("train.json")], threads);
        complete(&root, &["train", "--data", "data", "--train-step", "20", "--method", "eigenspace", "--out", &eig], threads);
        complete(&root, &["eval", "--model", &lin, "--data", "data", "--noise", "0.05", "--seed", "7", "--json", &m("eval-linear.json")], threads);
        complete(&root, &["eval", "--model", &eig, "--data", "data", "--noise", "0.05", "--seed", "7", "--json", &m("eval-eigen.json")], threads);
        let study = ["experiment", "--data", "data", "--train-step", "20", "--size-steps", "20,40", "--noise", "0,0.1", "--no-timings", "--out", &m("report")];
        complete(&root, &study, threads);
    }
    for other in ["b", "c"] {
        for f in ["linear.safetensors", "eigen.safetensors"] {
            assert!(
                std::fs::read(d.path(&format!("a-{f}"))).unwrap() == std::fs::read(d.path(&format!("{other}-{f}"))).unwrap(),
                "{f}: run a and run {other} differ"
            );
        }
        for f in ["train.json", "eval-linear.json", "eval-eigen.json"] {
            assert_eq!(untimed(&d.path(&format!("a-{f}"))), untimed(&d.path(&format!("{other}-{f}"))), "{f}: run a and run {other} differ");
        }
        let (ta, tb) = (tree(&d.path("a-report")), tree(&d.path(&format!("{other}-report"))));
        assert_eq!(ta.iter().map(|f| &f.0).collect::<Vec<_>>(), tb.iter().map(|f| &f.0).collect::<Vec<_>>());
        for ((name, a), (_, b)) in ta.iter().zip(&tb) {
            assert!(a == b, "report file {name}: run a and run {other} differ");
        }
    }
}
