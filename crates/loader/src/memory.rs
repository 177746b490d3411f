//! What this process may use of the machine, read before a build allocates, so that a table too
//! large for it is refused with the memory it needs rather than killed, or aborted, part way.
//!
//! Three limits can end a build: the physical memory, the address-space limit of the process
//! (`ulimit -v`, `RLIMIT_AS`) and the memory limit of its control group (a container's or a
//! systemd unit's `MemoryMax`). Each is read where Linux states it; a limit that cannot be read is
//! treated as absent, so other systems build as before, bounded by `tmlut`'s `recipes::MAX_BUILD_BYTES`.

use std::path::Path;

/// The smallest memory limit of this process, in bytes, with where it comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemoryLimit {
    /// The limit, in bytes.
    pub bytes: u64,
    /// Which limit it is and where it was read, in words (e.g. `ulimit -v`, a control group's file).
    pub source: String,
}

/// The smallest of the limits this process runs under, where any can be read.
pub fn memory_limit() -> Option<MemoryLimit> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let mut limits = Vec::new();
    if let Some(bytes) = read("/proc/meminfo").as_deref().and_then(physical_memory) {
        limits.push(MemoryLimit { bytes, source: "the machine's memory (/proc/meminfo MemTotal)".into() });
    }
    if let Some(bytes) = read("/proc/self/limits").as_deref().and_then(address_space_limit) {
        limits.push(MemoryLimit { bytes, source: "the process's address-space limit (ulimit -v)".into() });
    }
    if let Some(limit) =
        read("/proc/self/cgroup").as_deref().and_then(|c| control_group_limit(c, Path::new("/sys/fs/cgroup")))
    {
        limits.push(limit);
    }
    limits.into_iter().min_by_key(|l| l.bytes)
}

/// Where `needed` bytes are more than this process may use ([`memory_limit`]), the words that
/// say so: `{what} needs about N GiB; this process may use at most M GiB ({source})`.
pub fn beyond_limit(needed: u128, what: &str) -> Option<String> {
    let limit = memory_limit()?;
    (needed > u128::from(limit.bytes)).then(|| {
        format!(
            "{what} needs about {}; this process may use at most {} ({})",
            gib(needed),
            gib(u128::from(limit.bytes)),
            limit.source
        )
    })
}

/// Bytes as GiB, one decimal.
pub fn gib(bytes: u128) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn physical_memory(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft `Max address space` of `/proc/self/limits`, in bytes; `None` when unlimited.
fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

/// The memory limit of this process's control group: cgroup v2 (`0::/path` in `/proc/self/cgroup`,
/// `memory.max` under `root`) or v1 (the `memory` controller's `memory.limit_in_bytes`), the
/// smallest along the path up to the root, since every ancestor's limit also holds.
fn control_group_limit(cgroup: &str, root: &Path) -> Option<MemoryLimit> {
    let mut found: Option<MemoryLimit> = None;
    let mut keep = |bytes: u64, file: &Path| {
        if found.as_ref().is_none_or(|f| bytes < f.bytes) {
            found =
                Some(MemoryLimit { bytes, source: format!("the control group's memory limit ({})", file.display()) });
        }
    };
    for line in cgroup.lines() {
        let mut fields = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        let (base, file) = if controllers.is_empty() {
            (root.to_path_buf(), "memory.max")
        } else if controllers.split(',').any(|c| c == "memory") {
            (root.join("memory"), "memory.limit_in_bytes")
        } else {
            continue;
        };
        let mut dir = Some(Path::new(path.trim()));
        while let Some(d) = dir {
            let limit_file = base.join(d.strip_prefix("/").unwrap_or(d)).join(file);
            // "max" (v2) is no limit; v1 states no limit as a number near 2^63.
            if let Some(bytes) = std::fs::read_to_string(&limit_file).ok().and_then(|t| t.trim().parse::<u64>().ok())
                && bytes < 1 << 62
            {
                keep(bytes, &limit_file);
            }
            dir = d.parent();
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn physical_memory_and_the_address_space_limit_are_read_as_linux_states_them() {
        assert_eq!(physical_memory("MemFree: 1 kB\nMemTotal:       131072 kB\n"), Some(131072 * 1024));
        assert_eq!(physical_memory("nothing here"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                      Max address space         4096000000           unlimited            bytes     \n";
        assert_eq!(address_space_limit(limits), Some(4_096_000_000));
        let unlimited = "Max address space         unlimited            unlimited            bytes     \n";
        assert_eq!(address_space_limit(unlimited), None);
    }

    #[test]
    fn a_control_group_limit_is_the_smallest_on_the_way_to_the_root() {
        let root = tempfile::tempdir().unwrap();
        let leaf = root.path().join("a/b");
        std::fs::create_dir_all(&leaf).unwrap();
        std::fs::write(root.path().join("a/memory.max"), "4294967296\n").unwrap();
        std::fs::write(leaf.join("memory.max"), "max\n").unwrap();
        let limit = control_group_limit("0::/a/b\n", root.path()).unwrap();
        assert_eq!(limit.bytes, 4 << 30);
        assert!(limit.source.contains("a/memory.max"), "{}", limit.source);
        std::fs::write(leaf.join("memory.max"), "1073741824\n").unwrap();
        assert_eq!(control_group_limit("0::/a/b\n", root.path()).unwrap().bytes, 1 << 30);
        // v1: the memory controller's file; "no limit" is a number near 2^63.
        let v1 = root.path().join("memory/c");
        std::fs::create_dir_all(&v1).unwrap();
        std::fs::write(v1.join("memory.limit_in_bytes"), "9223372036854771712\n").unwrap();
        assert_eq!(control_group_limit("4:memory:/c\n", root.path()), None);
        std::fs::write(v1.join("memory.limit_in_bytes"), "2147483648\n").unwrap();
        assert_eq!(control_group_limit("4:cpu,memory:/c\n", root.path()).unwrap().bytes, 2 << 30);
    }
}
