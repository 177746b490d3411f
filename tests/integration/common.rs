//! Helpers of the tests that run `tmlut` on hostile input: each run in its own process, under a
//! memory limit and a time limit, classified by how it ended.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Address space a run may reserve: enough for any honest run of these tests, far below what a
/// size field read unchecked asks for (a reader that trusts one aborts instead of thrashing).
pub const MEMORY_LIMIT_KIB: u64 = 2 << 20;

/// How a run of `tmlut` ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Ending {
    /// Exit status 0.
    Success,
    /// Exit status 1 with one `error: ` message and no panic.
    CleanError,
    /// A Rust panic (exit status 101, or "panicked" on standard error).
    Panic,
    /// Killed by a signal (an allocation failure aborts with SIGABRT) or any other exit status.
    Abort,
    /// Still running at the time limit; killed.
    Hang,
}

/// The outcome of one run: how it ended and what it printed.
#[derive(Debug, Clone)]
pub struct Run {
    pub ending: Ending,
    pub stdout: String,
    pub stderr: String,
}

pub fn binary() -> &'static str {
    env!("CARGO_BIN_EXE_tmlut")
}

/// Run `tmlut args`, limited to [`MEMORY_LIMIT_KIB`] of address space (through the shell's
/// `ulimit -v`) and `time_limit` of wall time.
pub fn run_limited(args: &[&str], time_limit: Duration) -> Run {
    let script = format!("ulimit -v {MEMORY_LIMIT_KIB} && exec \"$0\" \"$@\"");
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(binary())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .env("RUST_BACKTRACE", "0")
        .spawn()
        .expect("sh runs");
    let started = Instant::now();
    let mut hung = false;
    loop {
        if child.try_wait().expect("waiting on tmlut").is_some() {
            break;
        }
        if started.elapsed() > time_limit {
            hung = true;
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let output = child.wait_with_output().expect("tmlut's output");
    classify(&output, hung)
}

pub fn classify(output: &Output, hung: bool) -> Run {
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    let ending = if hung {
        Ending::Hang
    } else if stderr.contains("panicked") || output.status.code() == Some(101) {
        Ending::Panic
    } else {
        match output.status.code() {
            Some(0) => Ending::Success,
            // 2: `check` could not run (or clap refused the arguments), a clean error as well.
            Some(1 | 2) if stderr.starts_with("error: ") => Ending::CleanError,
            _ => Ending::Abort,
        }
    };
    Run { ending, stdout, stderr }
}

/// Every table, small enough for the whole set to build in well under a second.
pub const SMALL_SET: &str = "
[fgd]
mu_count = 8
alpha_count = 7
eta_count = 6
kappa_count = 5
[fgd.sampling]
samples = 1024
replicates = 4
[fgd.reference]
cells = 4
nodes = 8
[fgd.interpolation]
points = 32
nodes = 6
[gd]
mu_count = 8
alpha_count = 8
[gd.sampling]
samples = 1024
replicates = 4
[gd.reference]
cells = 4
nodes = 8
[gd.interpolation]
points = 32
nodes = 6
[tir]
mu_count = 8
alpha_count = 8
eta_count = 8
[tir.sampling]
samples = 1024
replicates = 4
[tir.reference]
cells = 4
nodes = 8
[tir.interpolation]
points = 32
nodes = 6
[belcour]
mu_count = 16
roughness_count = 16
[belcour.sampling]
samples = 1024
replicates = 4
[belcour.reference]
cells = 4
nodes = 8
[belcour.interpolation]
points = 32
nodes = 6
[karis]
mu_count = 32
roughness_count = 24
[karis.sampling]
samples = 256
replicates = 4
[karis.reference]
cells = 6
nodes = 8
[karis.interpolation]
points = 32
nodes = 6
[fgd_rarer]
mu_count = 8
alpha_count = 7
fraction_count = 9
[fgd_rarer.sampling]
samples = 1024
replicates = 4
[fgd_rarer.reference]
cells = 4
nodes = 8
[fgd_rarer.interpolation]
points = 32
nodes = 6
";

/// [`SMALL_SET`] written in every format: FGD, GD and TIR also in the original `.bin` layout
/// (uniform axes, the only ones that layout can hold) beside their EXR, DDS and KTX2 files, FGD's
/// packing as DDS and KTX2.
pub fn small_set_in_every_format() -> String {
    let mut config = SMALL_SET.to_string();
    for (table, formats, more) in [
        (
            "fgd",
            r#"["bin", "exr"]"#,
            "eta_axis = \"uniform\"\nkappa_axis = \"uniform\"\npacking_formats = [\"dds\", \"ktx2\"]\n",
        ),
        ("gd", r#"["bin", "dds", "exr", "ktx2"]"#, ""),
        ("tir", r#"["bin", "dds", "exr", "ktx2"]"#, "eta_axis = \"eta\"\n"),
    ] {
        let header = format!("[{table}]\n");
        let uniform = format!("{header}mu_axis = \"uniform\"\nroughness_axis = \"alpha\"\n{more}");
        config = config.replacen(&header, &uniform, 1);
        config.push_str(&format!("[{table}.output]\nformats = {formats}\nprecision = \"f32\"\n"));
    }
    for table in ["belcour", "karis"] {
        config.push_str(&format!("[{table}.output]\nformats = [\"dds\", \"exr\", \"ktx2\"]\nprecision = \"f16\"\n"));
    }
    config.push_str("[fgd_rarer.output]\nformats = [\"dds\", \"exr\", \"ktx2\"]\nprecision = \"f32\"\n");
    config
}

/// Build [`SMALL_SET`] into `dir/luts` (with `extra` arguments) and return the folder.
pub fn small_build(dir: &Path, extra: &[&str]) -> PathBuf {
    build_config(dir, SMALL_SET, extra)
}

/// Build the configuration `text` into `dir/luts` (with `extra` arguments) and return the folder.
pub fn build_config(dir: &Path, text: &str, extra: &[&str]) -> PathBuf {
    let config = dir.join("small.toml");
    std::fs::write(&config, text).unwrap();
    let out = dir.join("luts");
    let mut args = vec!["build", "--quiet", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let output = Command::new(binary()).args(&args).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    out
}

/// Parse and validate every `.wgsl` file of `dir` with naga, as a WebGPU implementation does
/// before compiling it; returns how many were validated.
pub fn validate_wgsl_files(dir: &Path) -> usize {
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let text = std::fs::read_to_string(&path).unwrap();
            let module = naga::front::wgsl::parse_str(&text)
                .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&text)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&text)));
            count += 1;
        }
    }
    count
}

/// A cache entry's marker line and JSON body.
pub fn entry_parts(bytes: &[u8]) -> (String, serde_json::Value) {
    let newline = bytes.iter().position(|&b| b == b'\n').unwrap();
    let line = String::from_utf8(bytes[..newline].to_vec()).unwrap();
    (line, serde_json::from_slice(&bytes[newline + 1..]).unwrap())
}

/// `body` sealed under the marker of `line`, its SHA-256 recomputed: what an editor of the cache
/// can write.
pub fn resealed(line: &str, body: &serde_json::Value) -> Vec<u8> {
    let body = serde_json::to_vec(body).unwrap();
    let marker = &line[..line.rfind(' ').unwrap()];
    let mut bytes = format!("{marker} {}\n", tmlut::loader::sha256_hex(&body)).into_bytes();
    bytes.extend_from_slice(&body);
    bytes
}
