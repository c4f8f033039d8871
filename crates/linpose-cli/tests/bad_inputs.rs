//! The bad-input corpus: every kind of input a user or a file can throw at linpose, each answered
//! with an exit code and a message that names the problem, never a panic (ripgrep's and
//! image-rs's `tests/bad` are the model).
//!
//! Each [`Case`] runs in a fresh folder holding a copy of a small valid data set (`data/`, twelve
//! 16x12 images `a000.png` .. `a330.png`, azimuth every 30 degrees) and a linear model trained on
//! it (`m.safetensors`); the case copies files of `tests/bad/` over it, runs one command, and
//! checks the exit code (1: linpose refused the input; 2: the command line did not parse; 0: the
//! input is odd but valid) and the key words of the message. Text files of the corpus are
//! committed as they are; binary ones (images, model files) are made by [`gen`] and checked
//! against their committed copies by `binary_corpus_matches_its_generator`
//! (`LINPOSE_BLESS=1 cargo test -p linpose-cli --test bad_inputs` rewrites them).
//!
//! Regression inputs found by fuzzing (`fuzz/`) live in `tests/bad/fuzz/<target>/` and are run
//! through the same readers by `fuzz_regressions_do_not_panic`.

mod util;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use util::{write_dataset, Dir};

/// One bad input: corpus files to copy in, the command, the expected exit code and words.
struct Case {
    name: &'static str,
    /// (file under tests/bad/, destination relative to the case folder).
    files: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
    code: i32,
    words: &'static [&'static str],
}

const fn case(
    name: &'static str,
    files: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
    code: i32,
    words: &'static [&'static str],
) -> Case {
    Case { name, files, args, code, words }
}

const TRAIN: &[&str] = &["train", "--data", "data", "--out", "new.safetensors"];
const SYNTH_MESH: &[&str] = &["synth", "--mesh", "mesh.obj", "--out", "rendered", "--azimuth", "0:90:90", "--elevation", "30", "--size", "16x12"];

macro_rules! manifest {
    ($name:literal, $words:expr) => {
        case(concat!("manifest/", $name), &[(concat!("manifests/", $name, ".csv"), "data/poses.csv")], TRAIN, 1, $words)
    };
}
macro_rules! toml {
    ($name:literal, $words:expr) => {
        case(concat!("toml/", $name), &[(concat!("toml/", $name, ".toml"), "data/dataset.toml")], TRAIN, 1, $words)
    };
}
macro_rules! obj {
    ($name:literal, $code:expr, $words:expr) => {
        case(concat!("obj/", $name), &[(concat!("obj/", $name, ".obj"), "mesh.obj")], SYNTH_MESH, $code, $words)
    };
}
macro_rules! image {
    ($file:literal, $code:expr, $words:expr) => {
        case(concat!("image/", $file), &[(concat!("images/", $file), $file)], &["predict", "--model", "m.safetensors", $file], $code, $words)
    };
}
macro_rules! model {
    ($name:literal, $words:expr) => {
        case(
            concat!("model/", $name),
            &[(concat!("models/", $name, ".safetensors"), "bad.safetensors")],
            &["predict", "--model", "bad.safetensors", "data/a000.png"],
            1,
            $words,
        )
    };
}

const CASES: &[Case] = &[
    // Manifests (poses.csv).
    manifest!("no_header", &["poses.csv:1", "must start with 'image'", "a000.png"]),
    manifest!("missing_column", &["poses.csv:3", "1 fields", "header has 2"]),
    manifest!("extra_column", &["poses.csv:2", "3 fields", "header has 2"]),
    manifest!("nan_value", &["poses.csv:3", "not finite", "NaN"]),
    manifest!("inf_value", &["poses.csv:3", "not finite", "inf"]),
    manifest!("overflow_value", &["poses.csv:3", "not finite", "1e999"]),
    manifest!("blank_value", &["poses.csv:3", "missing value", "a030.png"]),
    manifest!("duplicate_row", &["poses.csv:4", "a000.png", "listed twice", "line 2"]),
    manifest!("parent_escape", &["../outside.png", "leaves the data folder"]),
    manifest!("absolute_path", &["/etc/hostname", "leaves the data folder"]),
    manifest!("nested_escape", &["sub/../../a030.png", "leaves the data folder"]),
    manifest!("non_utf8", &["poses.csv:3", "not valid UTF-8"]),
    manifest!("repeated_parameter", &["poses.csv:1", "'azimuth' appears twice"]),
    manifest!("empty_parameter_name", &["poses.csv:1", "empty parameter name"]),
    manifest!("no_parameters", &["poses.csv:1", "names no pose parameter"]),
    manifest!("empty_image_path", &["poses.csv:2", "empty image path"]),
    manifest!("degree_sign", &["poses.csv:2", "not a number", "45°"]),
    manifest!("unbalanced_quote", &["poses.csv:2", "1 fields"]),
    manifest!("zero_bytes", &["poses.csv:1", "empty file", "header"]),
    manifest!("empty_object_name", &["poses.csv:3", "empty object name", "a030.png"]),
    manifest!("repeated_object_column", &["poses.csv:1", "column 'object' appears twice"]),
    manifest!("object_column_only", &["poses.csv:1", "no pose parameter", "besides 'object'"]),
    // dataset.toml.
    toml!("unknown_key", &["dataset.toml:1", "unknown key 'perod'", "period, linear"]),
    toml!("unknown_parameter", &["dataset.toml:1", "'roll' is not a parameter", "azimuth"]),
    toml!("zero_period", &["dataset.toml:1", "period of 'azimuth'", "positive", "found 0"]),
    toml!("negative_period", &["dataset.toml:1", "period of 'azimuth'", "positive", "-360"]),
    toml!("nan_period", &["dataset.toml:1", "period of 'azimuth'", "positive", "nan"]),
    toml!("inf_period", &["dataset.toml:1", "period of 'azimuth'", "positive", "inf"]),
    toml!("string_period", &["dataset.toml:1", "period of 'azimuth'", "\"360\""]),
    toml!("period_and_linear", &["dataset.toml:1", "cannot have a period and be linear"]),
    toml!("not_a_table", &["dataset.toml:1", "must be a table"]),
    toml!("syntax_error", &["dataset.toml:1"]),
    toml!("neither", &["dataset.toml:1", "needs period = <degrees> or linear = true"]),
    // OBJ meshes (`linpose synth --mesh`).
    obj!("no_faces", 1, &["mesh.obj", "no faces", "3 vertex lines"]),
    obj!("index_out_of_range", 1, &["mesh.obj", "line 4", "refers to vertex 7", "3 vertices are defined"]),
    obj!("index_zero", 1, &["mesh.obj", "line 4", "refers to vertex 0"]),
    obj!("negative_index_out_of_range", 1, &["mesh.obj", "line 4", "refers to vertex -9", "before it"]),
    obj!("nan_vertex", 1, &["mesh.obj", "vertex 2", "non-finite"]),
    obj!("overflowing_vertex", 1, &["mesh.obj", "vertex 2", "non-finite"]),
    obj!("short_vertex", 1, &["mesh.obj", "not a valid Wavefront OBJ"]),
    obj!("comments_only", 1, &["mesh.obj", "no faces"]),
    obj!("coincident_vertices", 1, &["mesh.obj", "no extent"]),
    obj!("binary_garbage", 1, &["mesh.obj", "not a valid Wavefront OBJ"]),
    obj!("missing_mtl_is_fine", 0, &[]),
    // Images (`linpose predict` with the 16x12 model).
    image!("truncated.png", 1, &["truncated.png", "cannot decode"]),
    // The bytes, not the name, tell the format: a (cut) JPEG named .png is read as a JPEG.
    image!("jpeg_behind_png_name.png", 1, &["jpeg_behind_png_name.png", "JPEG data in a .png file"]),
    image!("text_behind_png_name.png", 1, &["text_behind_png_name.png", "not a PNG, PNM (PGM/PPM), JPEG or TIFF image"]),
    image!("huge_dimensions.png", 1, &["huge_dimensions.png", "100000x100000", "exceeds the limit"]),
    image!("huge_dimensions.pgm", 1, &["huge_dimensions.pgm", "65536x65536", "exceeds the limit"]),
    image!("zero_width.png", 1, &["zero_width.png", "cannot decode"]),
    image!("zero_dimensions.pgm", 1, &["zero_dimensions.pgm", "0x12", "no pixels"]),
    image!("bad_crc.png", 1, &["bad_crc.png", "cannot decode"]),
    image!("gray16.png", 0, &["gray16.png", "azimuth="]),
    image!("palette.png", 0, &["palette.png", "azimuth="]),
    image!("gray1bit.png", 0, &["gray1bit.png", "azimuth="]),
    image!("rgba16.png", 0, &["rgba16.png", "azimuth="]),
    // Refused from its header, before 512 MB of pixels are allocated for it.
    case("image/declares_8000x8000_in_a_16x12_set", &[("images/declares_8000x8000.png", "data/a030.png")], TRAIN, 1, &["a030.png", "8000x8000", "16x12"]),
    // Model files.
    model!("zero_bytes", &["bad.safetensors", "not a linpose model file"]),
    model!("header_cut", &["bad.safetensors", "not a linpose model file"]),
    model!("absurd_header_length", &["bad.safetensors", "not a linpose model file"]),
    model!("other_program", &["bad.safetensors", "safetensors file of another program"]),
    model!("no_metadata", &["bad.safetensors", "without linpose metadata"]),
    model!("no_format_version", &["bad.safetensors", "no format_version"]),
    model!("format_version_1", &["bad.safetensors", "format version 1", "earlier linpose", "reads version 7", "retrain"]),
    model!("format_version_8", &["bad.safetensors", "format version 8", "newer linpose", "reads version 7", "retrain"]),
    model!("shape_disagrees", &["bad.safetensors", "'weights'", "[2, 100]", "[2, 192]"]),
    model!("wrong_dtype", &["bad.safetensors", "'weights'", "dtype"]),
    model!("missing_tensor", &["bad.safetensors", "no tensor 'bias'"]),
    model!("unknown_method", &["bad.safetensors", "unknown method 'quadratic'", "linear, eigenspace"]),
    model!("damaged_metadata", &["bad.safetensors", "damaged metadata"]),
    model!("zero_image_size", &["bad.safetensors", "damaged metadata", "0x12"]),
    model!("nan_weights", &["bad.safetensors", "non-finite"]),
    model!("eigenspace_without_settings", &["bad.safetensors", "damaged eigenspace settings"]),
    model!("linear_without_pair_spread", &["bad.safetensors", "damaged linear settings", "pair_spread"]),
    model!("data_past_the_end", &["bad.safetensors", "not a linpose model file"]),
    // Command-line arguments.
    case("zero_azimuth_step", &[], &["synth", "--object", "duck", "--out", "o", "--azimuth", "0:90:0"], 1, &["azimuth", "STEP must be positive"]),
    case("negative_azimuth_step", &[], &["synth", "--object", "duck", "--out", "o", "--azimuth", "0:90:-3"], 1, &["azimuth", "STEP must be positive"]),
    case("reversed_elevation", &[], &["synth", "--object", "duck", "--out", "o", "--elevation", "60:30:3"], 1, &["elevation", "less than START"]),
    case("zero_size", &[], &["synth", "--object", "duck", "--out", "o", "--size", "0x0"], 1, &["--size", "WIDTHxHEIGHT"]),
    case("absurd_size", &[], &["synth", "--object", "duck", "--out", "o", "--size", "100000x100000"], 1, &["size", "100000x100000", "at most"]),
    case("negative_specular", &[], &["synth", "--object", "duck", "--out", "o", "--specular=-1"], 1, &["specular", "[0, 10]"]),
    case("unknown_object", &[], &["synth", "--object", "teapot", "--out", "o"], 1, &["teapot", "unknown built-in object", "duck"]),
    case(
        "synth_out_is_a_file",
        &[],
        &["synth", "--object", "duck", "--out", "m.safetensors", "--azimuth", "0", "--elevation", "30", "--size", "8x6"],
        1,
        &["m.safetensors", "not a folder"],
    ),
    case(
        "synth_out_not_empty",
        &[],
        &["synth", "--object", "duck", "--out", "data", "--azimuth", "0", "--elevation", "30", "--size", "8x6"],
        1,
        &["data", "not empty"],
    ),
    case(
        "zero_manifold_step",
        &[],
        &["train", "--data", "data", "--method", "eigenspace", "--manifold-step", "0", "--out", "e"],
        1,
        &["manifold step", "positive"],
    ),
    case(
        "negative_manifold_step",
        &[],
        &["train", "--data", "data", "--method", "eigenspace", "--manifold-step", "-0.5", "--out", "e"],
        1,
        &["manifold step", "positive"],
    ),
    case("zero_components", &[], &["train", "--data", "data", "--method", "eigenspace", "--components", "0", "--out", "e"], 1, &["components", "at least one"]),
    case("energy_above_one", &[], &["train", "--data", "data", "--method", "eigenspace", "--energy", "1.5", "--out", "e"], 1, &["energy", "(0, 1]"]),
    case(
        "unknown_interpolant",
        &[],
        &["train", "--data", "data", "--method", "refined", "--interpolant", "cubic", "--out", "e"],
        1,
        &["--interpolant cubic", "'spline', 'local' or 'auto'"],
    ),
    case(
        "bin_not_a_number",
        &[],
        &["train", "--data", "data", "--method", "refined", "--bin", "two", "--out", "e"],
        1,
        &["--bin two", "whole number or 'auto'"],
    ),
    case("nan_train_step", &[], &["train", "--data", "data", "--train-step", "nan", "--out", "e"], 1, &["train step", "positive"]),
    case(
        "negative_components",
        &[],
        &["train", "--data", "data", "--method", "eigenspace", "--components=-3", "--out", "e"],
        1,
        &["--components -3", "whole number"],
    ),
    // A setting of another method is refused, naming what the chosen method takes.
    case("setting_of_another_method", &[], &["train", "--data", "data", "--bin", "2", "--out", "e"], 1, &["--bin 2", "linear", "ridge, noise-level, center"]),
    case(
        "switch_of_another_method",
        &[],
        &["train", "--data", "data", "--method", "refined", "--center", "--out", "e"],
        1,
        &["--center", "refined", "does not take it"],
    ),
    case(
        "ridge_with_noise_level",
        &[],
        &["train", "--data", "data", "--ridge", "1", "--noise-level", "0.1", "--out", "e"],
        1,
        &["--noise-level 0.1", "cannot be given with ridge"],
    ),
    case(
        "stream_a_method_that_cannot",
        &[],
        &["train", "--data", "data", "--method", "refined", "--stream", "--out", "e"],
        1,
        &["--stream", "refined", "in memory only", "linear, eigenspace"],
    ),
    case("stream_with_ridge_auto", &[], &["train", "--data", "data", "--stream", "--ridge", "auto", "--out", "e"], 1, &["--ridge auto", "fixed ridge"]),
    case("unknown_method", &[], &["train", "--data", "data", "--method", "quadratic", "--out", "e"], 2, &["quadratic", "linear", "eigenspace", "refined"]),
    case("data_is_a_file", &[], &["train", "--data", "data/a000.png", "--out", "e"], 1, &["a000.png", "not a folder"]),
    case("model_out_in_missing_folder", &[], &["train", "--data", "data", "--out", "nowhere/m.safetensors"], 1, &["nowhere", "does not exist"]),
    case(
        "train_list_names_unknown_image",
        &[("lists/unknown_image.txt", "list.txt")],
        &["train", "--data", "data", "--train-list", "list.txt", "--out", "e"],
        1,
        &["a999.png", "not in the data set"],
    ),
    case(
        "train_list_empty",
        &[("lists/empty.txt", "list.txt")],
        &["train", "--data", "data", "--train-list", "list.txt", "--out", "e"],
        1,
        &["list.txt", "names no image"],
    ),
    case("negative_noise", &[], &["eval", "--model", "m.safetensors", "--data", "data", "--noise", "-0.1"], 1, &["--noise", "[0, 1]"]),
    case("nan_noise", &[], &["eval", "--model", "m.safetensors", "--data", "data", "--noise", "nan"], 1, &["--noise", "[0, 1]"]),
    case("eval_json_is_a_folder", &[], &["eval", "--model", "m.safetensors", "--data", "data", "--json", "data"], 1, &["data", "existing folder"]),
    case("model_is_a_folder", &[], &["eval", "--model", "data", "--data", "data"], 1, &["data"]),
    case(
        "predict_empty_folder",
        &[("lists/empty.txt", "empty/readme.txt")],
        &["predict", "--model", "m.safetensors", "empty"],
        1,
        &["empty", "no PNG, PGM, PPM, JPEG or TIFF image"],
    ),
    case("predict_no_images", &[], &["predict", "--model", "m.safetensors"], 2, &["IMAGE"]),
    case("unknown_subcommand", &[], &["frobnicate"], 2, &["frobnicate"]),
    // The options of many objects with one object's data set or model, and what a data set of
    // many objects (an object column) cannot do yet.
    case(
        "recognizer_with_one_object",
        &[],
        &["train", "--data", "data", "--recognizer", "linear", "--out", "e"],
        1,
        &["--recognizer", "for data sets of many objects", "data holds one"],
    ),
    case("leave_out_with_one_object", &[], &["train", "--data", "data", "--leave-out", "a", "--out", "e"], 1, &["--leave-out", "data holds one"]),
    case(
        "unknown_with_a_one_object_model",
        &[],
        &["eval", "--model", "m.safetensors", "--data", "data", "--unknown", "off"],
        1,
        &["--unknown", "m.safetensors", "one object's pose model"],
    ),
    case(
        "stream_many_objects",
        &[("manifests/two_objects.csv", "data/poses.csv")],
        &["train", "--data", "data", "--stream", "--out", "e"],
        1,
        &["data", "many objects", "--stream"],
    ),
    case(
        "leave_out_unknown_object",
        &[("manifests/two_objects.csv", "data/poses.csv")],
        &["train", "--data", "data", "--leave-out", "teapot", "--out", "e"],
        1,
        &["--leave-out teapot", "no such object", "left, right"],
    ),
    case(
        "one_object_model_on_many_objects",
        &[("manifests/two_objects.csv", "data/poses.csv")],
        &["eval", "--model", "m.safetensors", "--data", "data"],
        1,
        &["holds 2 objects (left, right)", "one object's pose model"],
    ),
    case("experiment_unknown_object", &[], &["experiment", "--quick", "--objects", "teapot", "--out", "r"], 1, &["teapot", "unknown built-in object"]),
    case("experiment_noise_above_one", &[], &["experiment", "--quick", "--noise", "0,2", "--out", "r"], 1, &["--noise 2", "[0, 1]"]),
    case("experiment_zero_train_step", &[], &["experiment", "--quick", "--train-step", "0", "--out", "r"], 1, &["--train-step", "positive"]),
    case("experiment_negative_size_step", &[], &["experiment", "--quick", "--size-steps=18,-9", "--out", "r"], 1, &["--size-steps", "-9", "positive"]),
    case("experiment_out_is_a_file", &[], &["experiment", "--quick", "--out", "m.safetensors"], 1, &["m.safetensors", "not a folder"]),
];

/// The corpus folder.
fn bad(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad").join(rel)
}

/// The valid data set and model every case starts from, made once per run of this test binary
/// under Cargo's temporary folder for integration tests.
fn base() -> &'static Path {
    static BASE: OnceLock<PathBuf> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_inputs_base");
        let _ = std::fs::remove_dir_all(&dir);
        write_dataset(&dir.join("data"), 30, &[], (16, 12));
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_linpose"))
            .args(["train", "--data", "data", "--out", "m.safetensors"])
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        dir
    })
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

/// Runs one case; returns what went wrong, if anything.
fn run_case(c: &Case) -> Option<String> {
    let d = Dir::new();
    copy_tree(base(), &d.path(""));
    for (src, dest) in c.files {
        let dest = d.path(dest);
        std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::fs::copy(bad(src), &dest).unwrap_or_else(|e| panic!("case {}: corpus file {src}: {e}", c.name));
    }
    let out = d.run(c.args);
    let err = String::from_utf8_lossy(&out.stderr);
    let all = format!("{}{err}", String::from_utf8_lossy(&out.stdout));
    let mut problems = Vec::new();
    if out.status.code() != Some(c.code) {
        problems.push(format!("exit code {:?}, expected {}", out.status.code(), c.code));
    }
    if err.contains("panicked") || err.contains("RUST_BACKTRACE") {
        problems.push("panicked".into());
    }
    if c.code != 0 && err.lines().filter(|l| !l.trim().is_empty()).count() == 0 {
        problems.push("no message".into());
    }
    for w in c.words {
        if !all.contains(w) {
            problems.push(format!("lacks '{w}'"));
        }
    }
    (!problems.is_empty()).then(|| format!("{}: linpose {:?}: {}\n    output: {}", c.name, c.args, problems.join("; "), all.trim()))
}

#[test]
fn every_bad_input_is_answered_with_its_exit_code_and_words() {
    let mut names = std::collections::HashSet::new();
    for c in CASES {
        assert!(names.insert(c.name), "case name {} is used twice", c.name);
    }
    // Run the cases a few at a time: each is one short process.
    let failures: Vec<String> = std::thread::scope(|s| {
        let chunks: Vec<_> = CASES.chunks(CASES.len().div_ceil(4)).map(|ch| s.spawn(move || ch.iter().filter_map(run_case).collect::<Vec<_>>())).collect();
        chunks.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), CASES.len(), failures.join("\n"));
}

#[test]
fn sixteen_bit_palette_and_one_bit_twins_estimate_like_the_8_bit_image() {
    // The same pixels stored four ways must give the same features, hence the same estimate.
    let d = Dir::new();
    copy_tree(base(), &d.path(""));
    let img = image::open(d.path("data/a090.png")).unwrap().to_luma8();
    let (w, h) = img.dimensions();
    std::fs::write(d.path("g16.png"), gen::gray16(w, h, img.as_raw())).unwrap();
    std::fs::write(d.path("pal.png"), gen::palette(w, h, img.as_raw())).unwrap();
    std::fs::write(d.path("g8.pgm"), gen::pgm(w, h, img.as_raw())).unwrap();
    let est = |f: &str| d.ok(&["predict", "--model", "m.safetensors", f]).trim().split("azimuth=").nth(1).unwrap().to_string();
    let want = est("data/a090.png");
    assert!(want.starts_with("90.0") || want.starts_with("89.99"), "{want}");
    for f in ["g16.png", "pal.png", "g8.pgm"] {
        assert_eq!(est(f), want, "{f}");
    }
}

/// The binary files of the corpus: (path under tests/bad/, bytes).
fn binary_corpus() -> Vec<(&'static str, Vec<u8>)> {
    let (w, h) = (16u32, 12u32);
    // A gentle gradient: any 16x12 image will do where only decoding is tested.
    let gray: Vec<u8> = (0..w * h).map(|i| ((i % w) * 13 + (i / w) * 7) as u8).collect();
    let good = gen::gray8(w, h, &gray);
    let mut bad_crc = good.clone();
    let n = bad_crc.len();
    bad_crc[n - 20] ^= 0x55; // inside the IDAT chunk's CRC
    let mut v = vec![
        ("images/truncated.png", good[..good.len() / 2].to_vec()),
        ("images/jpeg_behind_png_name.png", b"\xff\xd8\xff\xe0\x00\x10JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00\xff\xdb".to_vec()),
        ("images/huge_dimensions.png", gen::png_raw(100_000, 100_000, 8, 0, None, &[0u8; 64])),
        ("images/zero_width.png", gen::png_raw(0, 12, 8, 0, None, &[0u8; 12])),
        ("images/bad_crc.png", bad_crc),
        ("images/gray16.png", gen::gray16(w, h, &gray)),
        ("images/palette.png", gen::palette(w, h, &gray)),
        ("images/gray1bit.png", gen::gray1(w, h, &gray)),
        ("images/rgba16.png", gen::rgba16(w, h, &gray)),
        ("images/declares_8000x8000.png", gen::png_raw(8000, 8000, 16, 6, None, &[0u8; 64])),
        ("obj/binary_garbage.obj", (0..=255u8).cycle().take(600).collect()),
    ];
    v.extend(gen::models());
    v
}

#[test]
fn binary_corpus_matches_its_generator() {
    let bless = std::env::var_os("LINPOSE_BLESS").is_some();
    for (rel, bytes) in binary_corpus() {
        let path = bad(rel);
        if bless {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &bytes).unwrap();
        }
        let have = std::fs::read(&path).unwrap_or_else(|e| panic!("{rel}: {e}; run with LINPOSE_BLESS=1 to write it"));
        assert!(have == bytes, "{rel} differs from what the generator makes; run with LINPOSE_BLESS=1 to rewrite it");
    }
}

#[test]
fn fuzz_regressions_do_not_panic() {
    // Inputs the fuzz targets once crashed on: each must now give an answer through the same
    // command the target's reader serves, with exit code 0 or 1 (never a panic, 101).
    let d = Dir::new();
    copy_tree(base(), &d.path(""));
    let dir = bad("fuzz");
    // The folder is in the repository: missing, it is a broken checkout, not a reason to pass.
    let targets = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}: the fuzz regression inputs are missing", dir.display()));
    let mut ran = 0;
    for t in targets {
        let t = t.unwrap();
        let target = t.file_name().into_string().unwrap();
        for f in std::fs::read_dir(t.path()).unwrap() {
            let f = f.unwrap().path();
            let args: Vec<String> = match target.as_str() {
                "manifest" => {
                    std::fs::copy(&f, d.path("data/poses.csv")).unwrap();
                    TRAIN.iter().map(|s| s.to_string()).collect()
                }
                "dataset_toml" => {
                    std::fs::copy(base().join("data/poses.csv"), d.path("data/poses.csv")).unwrap();
                    std::fs::copy(&f, d.path("data/dataset.toml")).unwrap();
                    TRAIN.iter().map(|s| s.to_string()).collect()
                }
                "obj" => {
                    let _ = std::fs::remove_dir_all(d.path("rendered"));
                    std::fs::copy(&f, d.path("mesh.obj")).unwrap();
                    SYNTH_MESH.iter().map(|s| s.to_string()).collect()
                }
                "model_file" => {
                    std::fs::copy(&f, d.path("bad.safetensors")).unwrap();
                    ["predict", "--model", "bad.safetensors", "data/a000.png"].iter().map(|s| s.to_string()).collect()
                }
                other => panic!("unknown fuzz target folder {other}"),
            };
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = d.run(&args);
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(matches!(out.status.code(), Some(0 | 1)) && !err.contains("panicked"), "{}: {:?}: {err}", f.display(), out.status);
            let _ = std::fs::remove_file(d.path("data/dataset.toml"));
            ran += 1;
        }
    }
    assert!(ran > 0, "{}: no fuzz regression input", dir.display());
}

/// Deterministic makers of the binary corpus: PNGs with stored (uncompressed) deflate blocks, so
/// every byte is spelled out here, and safetensors files with hand-written headers.
mod gen {
    fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in data {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }

    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend(kind);
        out.extend(data);
        let crc = crc32(&out[start..]);
        out.extend(crc.to_be_bytes());
    }

    /// zlib stream of stored blocks.
    fn zlib_stored(data: &[u8]) -> Vec<u8> {
        let mut out = vec![0x78, 0x01];
        let blocks: Vec<&[u8]> = if data.is_empty() { vec![&[]] } else { data.chunks(65_535).collect() };
        for (i, b) in blocks.iter().enumerate() {
            out.push((i + 1 == blocks.len()) as u8);
            out.extend((b.len() as u16).to_le_bytes());
            out.extend((!(b.len() as u16)).to_le_bytes());
            out.extend(*b);
        }
        let (mut a, mut s) = (1u32, 0u32);
        for &x in data {
            a = (a + x as u32) % 65_521;
            s = (s + a) % 65_521;
        }
        out.extend(((s << 16) | a).to_be_bytes());
        out
    }

    /// A PNG of `raw` scanlines (each already prefixed by its filter byte).
    pub fn png_raw(w: u32, h: u32, depth: u8, colour: u8, plte: Option<&[u8]>, raw: &[u8]) -> Vec<u8> {
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut ihdr = Vec::new();
        ihdr.extend(w.to_be_bytes());
        ihdr.extend(h.to_be_bytes());
        ihdr.extend([depth, colour, 0, 0, 0]);
        chunk(&mut out, b"IHDR", &ihdr);
        if let Some(p) = plte {
            chunk(&mut out, b"PLTE", p);
        }
        chunk(&mut out, b"IDAT", &zlib_stored(raw));
        chunk(&mut out, b"IEND", &[]);
        out
    }

    fn scanlines(w: u32, h: u32, bytes_per_row: usize, row: impl Fn(u32, &mut Vec<u8>)) -> Vec<u8> {
        let mut raw = Vec::with_capacity(h as usize * (bytes_per_row + 1));
        for y in 0..h {
            raw.push(0);
            row(y, &mut raw);
        }
        let _ = w;
        raw
    }

    /// 8-bit gray.
    pub fn gray8(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let raw = scanlines(w, h, w as usize, |y, r| r.extend(&px[(y * w) as usize..((y + 1) * w) as usize]));
        png_raw(w, h, 8, 0, None, &raw)
    }

    /// 16-bit gray holding v * 257, which is v / 255 exactly once divided by 65535.
    pub fn gray16(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let raw = scanlines(w, h, 2 * w as usize, |y, r| {
            for &v in &px[(y * w) as usize..((y + 1) * w) as usize] {
                r.extend((v as u16 * 257).to_be_bytes());
            }
        });
        png_raw(w, h, 16, 0, None, &raw)
    }

    /// 8-bit palette of the 256 grays (index v is gray v).
    pub fn palette(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let plte: Vec<u8> = (0..=255u8).flat_map(|v| [v, v, v]).collect();
        let raw = scanlines(w, h, w as usize, |y, r| r.extend(&px[(y * w) as usize..((y + 1) * w) as usize]));
        png_raw(w, h, 8, 3, Some(&plte), &raw)
    }

    /// 1-bit gray: a pixel is white when v >= 128.
    pub fn gray1(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let bpr = (w as usize).div_ceil(8);
        let raw = scanlines(w, h, bpr, |y, r| {
            let row = &px[(y * w) as usize..((y + 1) * w) as usize];
            for byte in row.chunks(8) {
                r.push(byte.iter().enumerate().fold(0u8, |acc, (i, &v)| acc | (((v >= 128) as u8) << (7 - i))));
            }
        });
        png_raw(w, h, 1, 0, None, &raw)
    }

    /// 16-bit RGBA, gray with half-transparent alpha.
    pub fn rgba16(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let raw = scanlines(w, h, 8 * w as usize, |y, r| {
            for &v in &px[(y * w) as usize..((y + 1) * w) as usize] {
                let c = (v as u16 * 257).to_be_bytes();
                r.extend([c, c, c, 0x8000u16.to_be_bytes()].concat());
            }
        });
        png_raw(w, h, 16, 6, None, &raw)
    }

    /// Binary PGM.
    pub fn pgm(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        let mut out = format!("P5\n{w} {h}\n255\n").into_bytes();
        out.extend(px);
        out
    }

    /// A safetensors file: the 8-byte header length, the header (padded with spaces to 8 bytes)
    /// and the data.
    fn st(header: &str, data: &[u8]) -> Vec<u8> {
        let mut h = header.as_bytes().to_vec();
        while !h.len().is_multiple_of(8) {
            h.push(b' ');
        }
        let mut out = (h.len() as u64).to_le_bytes().to_vec();
        out.extend(h);
        out.extend(data);
        out
    }

    /// linpose.meta of a 16x12 azimuth model, JSON-escaped for the header.
    fn meta(method: &str, width: u32, settings: &str) -> String {
        let json = format!(
            r#"{{"method":"{method}","spec":{{"width":{width},"height":12,"color":"gray"}},"space":{{"params":[{{"name":"azimuth","period":360.0}}]}},"train_poses":[0.0,90.0],"settings":{settings}}}"#
        );
        serde_json::to_string(&json).unwrap()
    }

    fn header(format: &str, version: Option<&str>, meta: &str, tensors: &str) -> String {
        let version = version.map(|v| format!(r#","format_version":"{v}""#)).unwrap_or_default();
        format!(r#"{{"__metadata__":{{"format":"{format}"{version},"linpose.meta":{meta}}}{tensors}}}"#)
    }

    fn linear_tensors(weights_dtype: &str, weights_shape: &str, weights_len: usize) -> String {
        format!(
            r#","bias":{{"dtype":"F64","shape":[2],"data_offsets":[0,16]}},"weights":{{"dtype":"{weights_dtype}","shape":{weights_shape},"data_offsets":[16,{}]}}"#,
            16 + weights_len
        )
    }

    fn linear_data(weights: &[f32]) -> Vec<u8> {
        let mut d: Vec<u8> = [0f64, 0.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        d.extend(weights.iter().flat_map(|v| v.to_le_bytes()));
        d
    }

    /// The model-file corpus.
    pub fn models() -> Vec<(&'static str, Vec<u8>)> {
        let settings = r#"{"center":false,"ridge":0.0,"pair_spread":[0.1]}"#;
        let m = meta("linear", 16, settings);
        let w: Vec<f32> = (0..2 * 192).map(|i| (i % 5) as f32 * 1e-3).collect();
        let good = st(&header("linpose", Some("7"), &m, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w));
        let mut nan_w = w.clone();
        nan_w[7] = f32::NAN;
        let mut past_end = good.clone();
        past_end.truncate(good.len() - 4);
        vec![
            ("models/zero_bytes.safetensors", Vec::new()),
            ("models/header_cut.safetensors", good[..40].to_vec()),
            ("models/absurd_header_length.safetensors", [u64::MAX.to_le_bytes().as_slice(), b"{}      "].concat()),
            ("models/other_program.safetensors", st(r#"{"__metadata__":{"format":"pt"},"w":{"dtype":"F32","shape":[2],"data_offsets":[0,8]}}"#, &[0; 8])),
            ("models/no_metadata.safetensors", st(r#"{"w":{"dtype":"F32","shape":[2],"data_offsets":[0,8]}}"#, &[0; 8])),
            ("models/no_format_version.safetensors", st(&header("linpose", None, &m, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w))),
            ("models/format_version_1.safetensors", st(&header("linpose", Some("1"), &m, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w))),
            ("models/format_version_8.safetensors", st(&header("linpose", Some("8"), &m, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w))),
            ("models/shape_disagrees.safetensors", st(&header("linpose", Some("7"), &m, &linear_tensors("F32", "[2,100]", 4 * 200)), &linear_data(&w[..200]))),
            ("models/wrong_dtype.safetensors", st(&header("linpose", Some("7"), &m, &linear_tensors("I32", "[2,192]", 4 * 384)), &linear_data(&w))),
            (
                "models/missing_tensor.safetensors",
                st(&header("linpose", Some("7"), &m, r#","weights":{"dtype":"F32","shape":[2,192],"data_offsets":[0,1536]}"#), &linear_data(&w)[16..]),
            ),
            (
                "models/unknown_method.safetensors",
                st(&header("linpose", Some("7"), &meta("quadratic", 16, settings), &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w)),
            ),
            (
                "models/damaged_metadata.safetensors",
                st(&header("linpose", Some("7"), r##""{\"method\":\"linear\",\"spec\":""##, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w)),
            ),
            (
                "models/zero_image_size.safetensors",
                st(&header("linpose", Some("7"), &meta("linear", 0, settings), &linear_tensors("F32", "[2,0]", 0)), &linear_data(&[])),
            ),
            ("models/nan_weights.safetensors", st(&header("linpose", Some("7"), &m, &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&nan_w))),
            (
                "models/linear_without_pair_spread.safetensors",
                st(
                    &header("linpose", Some("7"), &meta("linear", 16, r#"{"center":false,"ridge":0.0}"#), &linear_tensors("F32", "[2,192]", 4 * 384)),
                    &linear_data(&w),
                ),
            ),
            (
                "models/eigenspace_without_settings.safetensors",
                st(&header("linpose", Some("7"), &meta("eigenspace", 16, "null"), &linear_tensors("F32", "[2,192]", 4 * 384)), &linear_data(&w)),
            ),
            ("models/data_past_the_end.safetensors", past_end),
        ]
    }
}
