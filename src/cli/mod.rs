//! The `tmlut` command line: one file per command, each its arguments (`#[derive(Args)]`) and its
//! `exec`. The work and the rendering of results live in the library; this layer parses
//! arguments, draws progress bars and turns errors into exit codes.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use tmlut::config::Config;
use tmlut::integrate::Progress;

mod audit;
mod bake;
mod bench;
mod build;
mod cache;
mod check;
mod converge;
mod fit;
mod furnace;
mod inspect;
mod list;
mod merge;
mod pack_report;
mod plan;
mod shader;
mod stability;

#[derive(Parser)]
#[command(
    name = "tmlut",
    version,
    about = "Integrate, write, check and inspect the lookup tables of transfer-matrix layered materials"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print no progress bars, only results and errors.
    #[arg(long, short, global = true)]
    quiet: bool,
}

#[derive(Subcommand)]
enum Command {
    Build(build::BuildArgs),
    Bake(bake::BakeArgs),
    Merge(merge::MergeArgs),
    Plan(plan::PlanArgs),
    Cache(cache::CacheArgs),
    Bench(bench::BenchArgs),
    Check(check::CheckArgs),
    Stability(stability::StabilityArgs),
    PackReport(pack_report::PackReportArgs),
    Converge(converge::ConvergeArgs),
    Fit(fit::FitArgs),
    Furnace(furnace::FurnaceArgs),
    Shader(shader::ShaderArgs),
    List(list::ListArgs),
    Inspect(inspect::InspectArgs),
    Audit(audit::AuditArgs),
}

/// What every command may use besides its own arguments.
pub struct Context {
    /// `--quiet`: no progress bars, and shorter reports where a command has a long form.
    pub quiet: bool,
}

impl Context {
    pub fn progress(&self) -> ProgressBars {
        ProgressBars::new(self.quiet)
    }
}

/// Run a command and give its exit status: 0 when it did what was asked, 1 when it failed. `check`
/// and `audit` tell a budget exceeded (1) from a folder or file they could not check (2; see
/// `check::exec`), so that CI tells a worse table from a broken job.
pub fn run(cli: Cli) -> ExitCode {
    let context = Context { quiet: cli.quiet };
    let result = match cli.command {
        Command::Build(args) => build::exec(args, &context),
        Command::Merge(args) => merge::exec(args, &context),
        Command::Plan(args) => plan::exec(args, &context),
        Command::Cache(args) => cache::exec(args, &context),
        Command::Bench(args) => bench::exec(args, &context),
        Command::Check(args) => return check::exec(args, &context),
        Command::Audit(args) => return audit::exec(args, &context),
        Command::Stability(args) => stability::exec(args, &context),
        Command::PackReport(args) => pack_report::exec(args, &context),
        Command::Converge(args) => converge::exec(args, &context),
        Command::Fit(args) => fit::exec(args, &context),
        Command::Furnace(args) => furnace::exec(args, &context),
        Command::Shader(args) => shader::exec(args, &context),
        Command::Bake(args) => bake::exec(args, &context),
        Command::List(args) => list::exec(args, &context),
        Command::Inspect(args) => inspect::exec(args, &context),
    };
    exit_status(result, ExitCode::FAILURE)
}

/// Print the error of `result`, if any, on standard error and give the status to exit with:
/// success, or `on_error`.
pub fn exit_status(result: tmlut::Result<()>, on_error: ExitCode) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            on_error
        }
    }
}

/// `--config`: the TOML configuration of the tables, read by [`ConfigArg::load`], the one place
/// every command reads it.
#[derive(Args)]
pub struct ConfigArg {
    /// TOML configuration of the tables (every key optional; default: the built-in defaults, as
    /// luts/default.toml spells them out).
    #[arg(long)]
    config: Option<PathBuf>,
}

impl ConfigArg {
    pub fn load(&self) -> tmlut::Result<Config> {
        Config::load(self.config.as_deref())
    }
}

/// The most worker threads `--threads` starts: results do not depend on the count, and far more
/// threads than cores only cost (each is started at once, with its own stack).
const MAX_THREADS: usize = 1024;

/// `--threads`: the size of the global worker pool.
#[derive(Args)]
pub struct ThreadsArg {
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
}

impl ThreadsArg {
    pub fn apply(&self) -> tmlut::Result<()> {
        let Some(threads) = self.threads else { return Ok(()) };
        if !(1..=MAX_THREADS).contains(&threads) {
            return Err(tmlut::Error::invalid("--threads", format!("{threads}; allowed: 1 to {MAX_THREADS}")));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|e| tmlut::Error::invalid("--threads", e.to_string()))
    }
}

/// A count given on the command line, refused outside `allowed` before anything is allocated or
/// run: an unbounded count aborts on its allocation (or overflows the arithmetic sizing it) long
/// after the option was read, with no word of which option it was.
pub fn check_count<T>(key: &str, value: T, allowed: std::ops::RangeInclusive<T>) -> tmlut::Result<()>
where
    T: PartialOrd + std::fmt::Display,
{
    if allowed.contains(&value) {
        Ok(())
    } else {
        Err(tmlut::Error::invalid(key, format!("{value}; allowed: {} to {}", allowed.start(), allowed.end())))
    }
}

/// The most samples per cell a sample-count option takes: a reference's points are held in memory
/// at once (about 24 bytes each, 400 MiB here), so the configuration's 2^32 would need 100 GiB.
pub const MAX_OPTION_SAMPLES: u64 = 1 << 24;

/// A sample count given on the command line must be a power of two, at most
/// [`MAX_OPTION_SAMPLES`].
pub fn check_sample_count(key: &str, samples: u64) -> tmlut::Result<()> {
    if samples > MAX_OPTION_SAMPLES {
        return Err(tmlut::Error::invalid(
            key,
            format!(
                "{samples}; allowed: a power of two from 2 to 2^24 = {MAX_OPTION_SAMPLES} (held in memory at once)"
            ),
        ));
    }
    tmlut::sampling::sequence::SamplePlan::new(samples, 1)
        .map(|_| ())
        .map_err(|e| tmlut::Error::invalid(key, e.to_string()))
}

/// A value named by one of `names`, for clap's `value_parser`: the error lists what is allowed.
pub fn one_of<T: Copy>(text: &str, choices: &[(&str, T)]) -> Result<T, String> {
    choices.iter().find(|(name, _)| *name == text).map(|&(_, value)| value).ok_or_else(|| {
        let names: Vec<&str> = choices.iter().map(|(name, _)| *name).collect();
        format!("`{text}`; allowed: {}", names.join(", "))
    })
}

/// One progress bar per long step, on standard error; nothing with `--quiet` or when standard
/// error is not a terminal (indicatif hides itself there).
pub struct ProgressBars {
    quiet: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl ProgressBars {
    fn new(quiet: bool) -> Self {
        ProgressBars { quiet, bar: Mutex::new(None) }
    }
}

impl Progress for ProgressBars {
    fn start(&self, label: &str, total: u64) {
        if self.quiet {
            return;
        }
        let bar = ProgressBar::new(total).with_message(label.to_string());
        bar.set_style(
            ProgressStyle::with_template("{msg:>16} [{bar:40}] {pos}/{len} cells, {per_sec}, {elapsed} (eta {eta})")
                .expect("the template is valid")
                .progress_chars("=> "),
        );
        *self.bar.lock().expect("progress lock") = Some(bar);
    }

    fn advance(&self, done: u64) {
        if let Some(bar) = &*self.bar.lock().expect("progress lock") {
            bar.inc(done);
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }

    fn note(&self, message: &str) {
        eprintln!("note: {message}");
    }
}
