//! The machine's side of the plan: how much memory is available to this process, and sizes in
//! bytes read from and written for people.
//!
//! Available memory is the smallest of what the kernel says a new allocation can get without
//! swapping (`MemAvailable` in `/proc/meminfo`) and what the process's control groups leave
//! (each memory-limited cgroup from the process's own up to the root: v2 `memory.max` minus
//! `memory.current`, v1 `memory.limit_in_bytes` minus `memory.usage_in_bytes`, each usage less
//! its inactive file cache, which the kernel reclaims before it kills). A container's limit is
//! thus seen even where `/proc/meminfo` shows the whole host. Unreadable figures are skipped:
//! kernels before 3.14 have no `MemAvailable`, and free memory plus buffers and cache stands in
//! for it; where nothing can be read (not Linux), the available memory is unknown and the plan
//! checks a budget only when one is given ([`super::Limit::Unknown`]).

use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// What the machine has available for this process, and where the figure comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Available {
    /// Bytes.
    pub bytes: u64,
    /// Whether a control group's limit (not the machine's free memory) set it.
    pub cgroup: bool,
}

/// The memory available to this process: the least of `MemAvailable` and what the cgroups'
/// limits leave (see [`crate::memory`]); None when no figure can be read.
pub(crate) fn available() -> Option<Available> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| meminfo_available(&t));
    let cgroup = std::fs::read_to_string("/proc/self/cgroup").ok().and_then(|t| cgroup_available(&t, Path::new("/sys/fs/cgroup")));
    match (meminfo, cgroup) {
        (Some(m), Some(c)) if c < m => Some(Available { bytes: c, cgroup: true }),
        (Some(m), _) => Some(Available { bytes: m, cgroup: false }),
        (None, Some(c)) => Some(Available { bytes: c, cgroup: true }),
        (None, None) => None,
    }
}

/// `MemAvailable` of a `/proc/meminfo` text in bytes, or `MemFree + Buffers + Cached` where the
/// kernel is too old to say.
pub(crate) fn meminfo_available(text: &str) -> Option<u64> {
    let field = |name: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.split(':').next() == Some(name))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        kib.checked_mul(1024)
    };
    field("MemAvailable").or_else(|| Some(field("MemFree")? + field("Buffers").unwrap_or(0) + field("Cached").unwrap_or(0)))
}

/// What the memory-limited cgroups of a `/proc/self/cgroup` text leave, the cgroup file systems
/// mounted at `root`: the least over the process's cgroup and its ancestors, v2 and v1.
pub(crate) fn cgroup_available(text: &str, root: &Path) -> Option<u64> {
    let mut least: Option<u64> = None;
    for line in text.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next()) else { continue };
        let (base, limit, usage, inactive): (Vec<PathBuf>, _, _, _) = if controllers.is_empty() {
            (vec![root.to_path_buf(), root.join("unified")], "memory.max", "memory.current", "inactive_file")
        } else if controllers.split(',').any(|c| c == "memory") {
            (vec![root.join("memory")], "memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file")
        } else {
            continue;
        };
        for base in base {
            // The cgroup's folder, or the mount's root where a namespace hides the path.
            let leaf = base.join(path.trim_start_matches('/'));
            let start = if leaf.is_dir() { leaf } else { base.clone() };
            for dir in start.ancestors().take_while(|d| d.starts_with(&base)) {
                let read = |f: &str| std::fs::read_to_string(dir.join(f)).ok();
                let Some(max) = read(limit).and_then(|v| v.trim().parse::<u64>().ok()) else { continue };
                let used = read(usage).and_then(|v| v.trim().parse::<u64>().ok()).unwrap_or(0);
                let cache = read("memory.stat").and_then(|s| stat_field(&s, inactive)).unwrap_or(0);
                let left = max.saturating_sub(used.saturating_sub(cache));
                least = Some(least.map_or(left, |l| l.min(left)));
            }
        }
    }
    least
}

/// A `memory.stat` field's value.
fn stat_field(text: &str, name: &str) -> Option<u64> {
    text.lines().find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
}

/// A size in bytes as people write it: a number, optionally with a unit `K`, `M`, `G` or `T`
/// (any case, optionally followed by `B` or `iB`), each a power of 1024 (`8G` = `8GiB` =
/// 8 x 2^30 bytes, as `docker --memory` and systemd read them), e.g. `512M`, `1.5G`, `8GiB`,
/// `1048576`. A value that is not one, or is zero, is an error naming it.
pub fn parse_size(text: &str) -> Result<u64> {
    let bad = |reason: &str| Error::invalid("memory size", text, reason);
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = (&t[..split], t[split..].trim());
    let value: f64 = number.parse().map_err(|_| bad("expected a number of bytes, optionally with K, M, G or T (e.g. 512M, 8G, 1.5GiB)"))?;
    let power = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 1,
        "m" | "mb" | "mib" => 2,
        "g" | "gb" | "gib" => 3,
        "t" | "tb" | "tib" => 4,
        _ => return Err(bad(&format!("unknown unit '{unit}': use K, M, G or T (powers of 1024), e.g. 512M, 8G"))),
    };
    let bytes = value * 1024f64.powi(power);
    if !(bytes >= 1.0) {
        return Err(bad("must be at least one byte"));
    }
    if bytes >= u64::MAX as f64 {
        return Err(bad("too large"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::format_bytes;

    #[test]
    fn sizes_are_read_in_powers_of_1024() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("8G").unwrap(), 8 << 30);
        assert_eq!(parse_size("8GiB").unwrap(), 8 << 30);
        assert_eq!(parse_size("8gb").unwrap(), 8 << 30);
        assert_eq!(parse_size("1.5G").unwrap(), 3 << 29);
        assert_eq!(parse_size(" 2 T ").unwrap(), 2 << 40);
        assert_eq!(parse_size("1048576").unwrap(), 1 << 20);
        assert_eq!(parse_size("100k").unwrap(), 102_400);
        for bad in ["", "G", "8X", "-1G", "0", "1.2.3G", "eight", "8 GiBs", "nan", "0.1"] {
            let e = parse_size(bad).unwrap_err().to_string();
            assert!(e.contains("memory size") && e.contains(bad.trim()), "{bad}: {e}");
        }
    }

    #[test]
    fn bytes_are_written_for_people() {
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(1536), "1.5 KiB");
        assert_eq!(format_bytes(512 << 20), "512.0 MiB");
        assert_eq!(format_bytes(87_200_000_000), "81.2 GiB");
    }

    #[test]
    fn meminfo_gives_mem_available_or_free_plus_cache() {
        let new =
            "MemTotal:       24000000 kB\nMemFree:        20532336 kB\nMemAvailable:   23550784 kB\nBuffers:           93828 kB\nCached:          2864672 kB\n";
        assert_eq!(meminfo_available(new), Some(23_550_784 * 1024));
        let old = "MemTotal:       24000000 kB\nMemFree:        1000 kB\nBuffers:           10 kB\nCached:          100 kB\n";
        assert_eq!(meminfo_available(old), Some(1110 * 1024));
        assert_eq!(meminfo_available("nothing here"), None);
    }

    /// A cgroup v2 tree and a v1 one written to a temporary folder: the least of the limited
    /// levels, each less its usage net of inactive file cache; unlimited levels skipped.
    #[test]
    fn cgroup_limits_are_read_up_the_tree() {
        let dir = std::env::temp_dir().join(format!("linpose-cgroup-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let write = |rel: &str, text: &str| {
            let p = dir.join(rel);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        };
        // v2: the job's cgroup is unlimited, its parent leaves 4 GiB - (3 GiB - 1 GiB cache).
        write("a/job/memory.max", "max\n");
        write("a/job/memory.current", "100\n");
        write("a/memory.max", &format!("{}\n", 4u64 << 30));
        write("a/memory.current", &format!("{}\n", 3u64 << 30));
        write("a/memory.stat", &format!("anon 5\ninactive_file {}\nactive_file 7\n", 1u64 << 30));
        assert_eq!(cgroup_available("0::/a/job\n", &dir), Some(2 << 30));
        // v1: the memory controller's line only; an unlimited (huge) limit counts as such.
        write("memory/b/memory.limit_in_bytes", &format!("{}\n", 1u64 << 30));
        write("memory/b/memory.usage_in_bytes", &format!("{}\n", 1u64 << 29));
        write("memory/memory.limit_in_bytes", "9223372036854771712\n");
        write("memory/memory.usage_in_bytes", "0\n");
        assert_eq!(cgroup_available("4:memory:/b\n3:cpu:/b\n", &dir), Some(1 << 29));
        // No memory controller, or no files: nothing.
        assert_eq!(cgroup_available("3:cpu:/b\n", &dir), None);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(cgroup_available("0::/\n", &dir), None);
    }
}
