//! The replay of a fuzz target's corpus on the stable toolchain.
//!
//! Built by cargo-fuzz (`--cfg fuzzing`), each target is libFuzzer's; built plainly (`cargo
//! build --manifest-path fuzz/Cargo.toml`), its `main` calls [`replay`] or [`replay_str`], which
//! run the target's body on every file named on the command line or held in a folder named there,
//! so CI builds every target and runs it over its corpus without nightly or cargo-fuzz. A panic
//! in the body ends the process with a failure status, naming the input.

use std::path::{Path, PathBuf};

/// A target's two entry points for its `body`: libFuzzer's under cargo-fuzz (`--cfg fuzzing`),
/// else a `main` that replays the corpus ([`replay`] for `bytes`, [`replay_str`] for `text`).
/// Each target file starts with `#![cfg_attr(fuzzing, no_main)]` and then calls this once.
#[macro_export]
macro_rules! target {
    (bytes: $body:path) => {
        #[cfg(fuzzing)]
        libfuzzer_sys::fuzz_target!(|bytes: &[u8]| $body(bytes));
        #[cfg(not(fuzzing))]
        fn main() {
            $crate::replay($body);
        }
    };
    (text: $body:path) => {
        #[cfg(fuzzing)]
        libfuzzer_sys::fuzz_target!(|text: &str| $body(text));
        #[cfg(not(fuzzing))]
        fn main() {
            $crate::replay_str($body);
        }
    };
}

/// The files of the paths given as arguments: a file itself, a folder's files (sorted by name,
/// not recursing). A path that does not exist, or a folder without a file, is an error: a corpus
/// that is not there would replay nothing and pass.
fn inputs() -> Vec<PathBuf> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    if args.is_empty() {
        fail("usage: TARGET FILE_OR_FOLDER...: replays the target's body on every input");
    }
    let mut out = Vec::new();
    for a in &args {
        if a.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(a)
                .unwrap_or_else(|e| fail(&format!("{}: {e}", a.display())))
                .map(|e| e.unwrap_or_else(|e| fail(&format!("{}: {e}", a.display()))).path())
                .filter(|p| p.is_file())
                .collect();
            if files.is_empty() {
                fail(&format!("{}: the folder holds no input", a.display()));
            }
            files.sort();
            out.extend(files);
        } else if a.is_file() {
            out.push(a.clone());
        } else {
            fail(&format!("{}: no such file or folder", a.display()));
        }
    }
    out
}

fn fail(message: &str) -> ! {
    eprintln!("replay: {message}");
    std::process::exit(2)
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| fail(&format!("{}: {e}", path.display())))
}

/// Runs `body` on the bytes of every input named on the command line (see the module's doc).
pub fn replay(body: impl Fn(&[u8])) {
    let files = inputs();
    for f in &files {
        eprintln!("replay: {}", f.display());
        body(&read(f));
    }
    println!("replayed {} inputs", files.len());
}

/// [`replay`] for a target of text: as libFuzzer's `fuzz_target!(|s: &str| ..)` (arbitrary's
/// `&str` from the whole input), an input that is not UTF-8 gives its longest UTF-8 prefix.
pub fn replay_str(body: impl Fn(&str)) {
    let files = inputs();
    let mut cut = 0;
    for f in &files {
        let bytes = read(f);
        let text = match std::str::from_utf8(&bytes) {
            Ok(s) => s,
            Err(e) => {
                cut += 1;
                std::str::from_utf8(&bytes[..e.valid_up_to()]).expect("a valid prefix")
            }
        };
        eprintln!("replay: {}", f.display());
        body(text);
    }
    println!("replayed {} inputs ({cut} not UTF-8: their UTF-8 prefix, as libFuzzer's &str target)", files.len());
}
