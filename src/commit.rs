//! How a build takes an output folder and moves its files into it, so that the folder always
//! answers for its manifest (`docs/formats.md`, "How a build commits").
//!
//! - **One build at a time.** A build holds an advisory lock on `.tmlut.lock` in the folder (fs4:
//!   `flock` on Unix, `LockFileEx` on Windows) from before it reads the manifest until its commit
//!   is complete. A second build waits for it. The kernel releases the lock when its holder dies,
//!   whatever PID namespace or host it runs in (on NFS through the lock manager), so "no one
//!   holds the lock" is proof that nothing else is writing the folder.
//! - **Staging.** Every file of the build, the new `manifest.json` included, is written and
//!   synced in a staging folder inside the output folder before anything in the folder changes.
//! - **The commit point** is the journal `.tmlut-commit.json` (written through a temporary file,
//!   synced, renamed): from then on the build counts as done. Its files are renamed into place
//!   one by one, the manifest last, then the journal is removed.
//! - **Recovery.** A build that holds the lock first completes any commit the journal records
//!   (the staged files are still in their staging folder), then removes every other staging
//!   folder and temporary file: under the lock they are provably abandoned.
//!
//! So after a failure or a kill at any instant, the folder holds the old build or the new one, or
//! a journal. The loader and `tmlut check` refuse a folder with a journal, and verify every file
//! against the manifest's SHA-256 besides; the next build completes the commit.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::formats::files::{is_temporary, open_lock_file, unpredictable_name};
use crate::formats::manifest::{COMMIT_JOURNAL, MANIFEST_FILE, check_file_name};
use crate::formats::{MAX_MANIFEST_BYTES, read_bytes_at_most, write_bytes_atomically};

/// The lock file of an output folder.
pub const LOCK_FILE: &str = ".tmlut.lock";

/// Folders a build writes its files into before the commit: `.tmlut-staging-<unpredictable>`.
const STAGING_PREFIX: &str = ".tmlut-staging-";

/// The subfolder of an output folder that holds error maps.
pub const MAPS_FOLDER: &str = "maps";

/// Subfolders a build may write into (error maps); every other destination is a plain file name.
const SUBFOLDERS: &[&str] = &[MAPS_FOLDER];

/// An output folder held by this build: created if needed, locked, and cleared of what earlier
/// builds left (an interrupted commit completed, abandoned staging folders removed).
pub struct OutputFolder {
    pub dir: PathBuf,
    /// Held open for the lock's lifetime; closing it releases the lock.
    lock: File,
}

impl OutputFolder {
    /// Take `dir` for a build: create it, lock it (waiting for another build that holds it, after
    /// `on_wait` is told why), and clear it of what interrupted builds left.
    pub fn take(dir: &Path, on_wait: impl FnOnce(&str)) -> Result<Self> {
        if let Ok(metadata) = dir.metadata()
            && !metadata.is_dir()
        {
            return Err(Error::format(dir, "is a file; the output folder must be a folder, or not exist yet"));
        }
        std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
        let path = dir.join(LOCK_FILE);
        let mut on_wait = Some(on_wait);
        let lock = loop {
            // Never through a link, nor into a file of several links: the lock's holder line is
            // the one write tmlut makes in place.
            let lock = open_lock_file(&path)?;
            match fs4::FileExt::try_lock(&lock) {
                Ok(()) => {}
                Err(fs4::TryLockError::WouldBlock) => {
                    if let Some(on_wait) = on_wait.take() {
                        let mut holder = String::new();
                        let _ = std::io::Read::read_to_string(&mut std::io::Read::take(&lock, 256), &mut holder);
                        on_wait(&format!(
                            "waiting for the build that holds {} ({}) to finish",
                            path.display(),
                            holder.trim().trim_end_matches('.')
                        ));
                    }
                    fs4::FileExt::lock(&lock).map_err(|source| Error::io(&path, source))?;
                }
                Err(fs4::TryLockError::Error(source)) => return Err(Error::io(&path, source)),
            }
            // The build we waited for removes the lock file as it ends; a lock on the removed file
            // excludes no one, so take the one at the path.
            if is_the_file_at(&lock, &path) {
                break lock;
            }
        };
        // Who holds it, for the message of a build that waits (not used for anything else).
        let _ = lock.set_len(0).and_then(|()| writeln!(&lock, "pid {}.", std::process::id()));
        let folder = OutputFolder { dir: dir.to_path_buf(), lock };
        complete_interrupted_commit(dir)?;
        remove_abandoned(dir);
        Ok(folder)
    }

    /// A new staging folder for this build, created exclusively under a name no other process
    /// can predict: nothing planted in the folder can be where the build writes its files.
    pub fn staging(&self) -> Result<Staging> {
        let mut tries = 0;
        loop {
            let dir = self.dir.join(format!("{STAGING_PREFIX}{}", unpredictable_name()));
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(Staging { dir, keep: false }),
                // A name taken (by chance, or planted) is passed over for another.
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && tries < 16 => tries += 1,
                Err(source) => return Err(Error::io(&dir, source)),
            }
        }
    }
}

impl Drop for OutputFolder {
    /// Remove the lock file, then release the lock: a build waiting on it sees that the file it
    /// locked is no longer the one at the path, and takes a new one ([`OutputFolder::take`]).
    fn drop(&mut self) {
        if cfg!(unix) {
            let _ = std::fs::remove_file(self.dir.join(LOCK_FILE));
        }
        let _ = fs4::FileExt::unlock(&self.lock);
    }
}

/// Whether the open `file` is the file now at `path` (same device and inode). Where the lock file
/// is never removed (not Unix), it always is.
fn is_the_file_at(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), path.metadata()) {
            (Ok(open), Ok(named)) => open.dev() == named.dev() && open.ino() == named.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        true
    }
}

/// The folder a build writes into before its commit; removed with whatever is left in it when the
/// build ends, unless a commit that needs its files is pending.
pub struct Staging {
    pub dir: PathBuf,
    keep: bool,
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// One staged file and where it goes, relative to the staging folder and the output folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Move {
    pub staged: String,
    pub destination: String,
}

/// The record of a commit in progress: which staging folder holds the files, every rename still to
/// do, the manifest last, and the files of the earlier build that the new manifest no longer
/// lists, removed after it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Journal {
    staging: String,
    moves: Vec<Move>,
    #[serde(default)]
    removals: Vec<String>,
}

/// A point where a commit touches the file system: a test can make it fail there, as a full disk
/// or a kill would.
#[cfg(test)]
pub(crate) mod faults {
    use std::cell::Cell;

    thread_local! {
        /// Fail at the fault point of this number (0 = the first); `None`: never.
        pub static FAIL_AT: Cell<Option<usize>> = const { Cell::new(None) };
        /// Fault points passed so far.
        pub static PASSED: Cell<usize> = const { Cell::new(0) };
    }

    pub fn point(what: &str) -> std::io::Result<()> {
        let passed = PASSED.with(|p| p.replace(p.get() + 1));
        if FAIL_AT.with(Cell::get) == Some(passed) {
            return Err(std::io::Error::other(format!("injected fault before {what}")));
        }
        Ok(())
    }
}

#[cfg(not(test))]
mod faults {
    #[inline(always)]
    pub fn point(_what: &str) -> std::io::Result<()> {
        Ok(())
    }
}

/// Move the staged files (the staged manifest among them, moved last) into the folder, then remove
/// `removals`, files of the folder that the new manifest no longer lists.
///
/// Everything that can be checked is checked before the journal is written: every destination is
/// named once, a plain file name (or one under a known subfolder), and free or a regular file, not
/// a folder. A failure before the journal leaves the folder as it was; after it, the journal and
/// the staging folder stay for the next build to complete.
pub fn commit(folder: &OutputFolder, staging: &mut Staging, moves: Vec<Move>, removals: Vec<String>) -> Result<()> {
    commit_set(folder, staging, moves, removals, MANIFEST_FILE)
}

/// [`commit`] with `last` in place of the manifest: the staged file that lists the set (a furnace
/// run's `furnace.json`), moved into place after every file it lists.
pub fn commit_set(
    folder: &OutputFolder,
    staging: &mut Staging,
    mut moves: Vec<Move>,
    mut removals: Vec<String>,
    last: &str,
) -> Result<()> {
    let out = &folder.dir;
    check_destinations(out, &moves, last)?;
    // A damaged manifest may name paths outside the folder: those are never touched.
    removals.retain(|file| check_destination_name(file).is_ok() && not_a_link_on_the_way(out, file).is_ok());
    moves.push(Move { staged: last.into(), destination: last.into() });
    sync_dir(&staging.dir).map_err(|source| Error::io(&staging.dir, source))?;
    let staging_name = staging.dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let journal = Journal { staging: staging_name, moves, removals };
    // The same rule the next build applies to a journal it finds: a journal this build could not
    // complete is never written.
    check_journal(out, &journal).map_err(|reason| Error::format(out, format!("{reason} (nothing was changed)")))?;
    let text = serde_json::to_string_pretty(&journal).expect("a journal is plain data");
    let journal_path = out.join(COMMIT_JOURNAL);
    faults::point("writing the journal").map_err(|source| Error::io(&journal_path, source))?;
    // From here on the staged files belong to the commit.
    staging.keep = true;
    if let Err(e) = write_bytes_atomically(&journal_path, text.as_bytes()) {
        // The journal never reached its name: nothing in the folder changed.
        staging.keep = false;
        return Err(e);
    }
    replay(out, &journal).map_err(|e| {
        Error::format(
            out,
            format!(
                "{e}; the build is committed but only partly in place: the next `tmlut build` into this folder \
                 completes it, and until then the loader and `tmlut check` refuse the folder"
            ),
        )
    })?;
    staging.keep = false;
    Ok(())
}

/// Refuse destinations a rename would fail on or that two files share, before anything moves.
fn check_destinations(out: &Path, moves: &[Move], last: &str) -> Result<()> {
    let mut seen = std::collections::BTreeSet::new();
    for m in moves {
        check_destination_name(&m.destination).map_err(|reason| Error::format(out.join(&m.destination), reason))?;
        // Compared as a case-insensitive file system compares them: two names that differ only in
        // case are one file there.
        if m.destination.eq_ignore_ascii_case(last) || !seen.insert(m.destination.to_ascii_lowercase()) {
            return Err(Error::invalid(
                format!("output file `{}`", m.destination),
                "two files of this build have this name, or names that differ only in case, one file on a \
                 case-insensitive file system (a format listed twice, two tables or materials of one name); each \
                 file must be written once",
            ));
        }
        let path = out.join(&m.destination);
        if let Ok(metadata) = path.symlink_metadata()
            && metadata.is_dir()
        {
            return Err(Error::format(
                &path,
                "is a folder where the build writes a file; move it out of the way (nothing was changed)",
            ));
        }
    }
    for subfolder in SUBFOLDERS {
        let path = out.join(subfolder);
        if moves.iter().any(|m| m.destination.starts_with(&format!("{subfolder}/")))
            && path.symlink_metadata().is_ok_and(|m| !m.is_dir())
        {
            return Err(Error::format(&path, "is a file where the build writes a folder (nothing was changed)"));
        }
    }
    Ok(())
}

/// A file name inside the folder, or one under a known subfolder.
fn check_destination_name(name: &str) -> std::result::Result<(), String> {
    match name.split_once('/') {
        Some((folder, file)) if SUBFOLDERS.contains(&folder) => check_file_name(file),
        _ => check_file_name(name),
    }
}

/// Do every rename the journal records (those already done are skipped), then remove the
/// journal and the staging folder.
fn replay(out: &Path, journal: &Journal) -> std::io::Result<()> {
    let staging = out.join(&journal.staging);
    for subfolder in SUBFOLDERS {
        if journal.moves.iter().any(|m| m.destination.starts_with(&format!("{subfolder}/"))) {
            faults::point("creating a subfolder")?;
            std::fs::create_dir_all(out.join(subfolder))?;
        }
    }
    for m in &journal.moves {
        let (from, to) = (staging.join(&m.staged), out.join(&m.destination));
        faults::point("a rename")?;
        match std::fs::rename(&from, &to) {
            Ok(()) => {}
            // Moved before an interruption: only the destination is left.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && to.symlink_metadata().is_ok() => {}
            Err(e) => {
                return Err(std::io::Error::new(
                    e.kind(),
                    format!("moving {} to {}: {e}", from.display(), to.display()),
                ));
            }
        }
    }
    for file in &journal.removals {
        faults::point("a removal")?;
        match std::fs::remove_file(out.join(file)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
            _ => {}
        }
    }
    faults::point("syncing the folder")?;
    sync_dir(out)?;
    faults::point("removing the journal")?;
    std::fs::remove_file(out.join(COMMIT_JOURNAL))?;
    sync_dir(out)?;
    let _ = std::fs::remove_dir_all(&staging);
    Ok(())
}

/// Complete the commit a journal records, if there is one (the caller holds the lock).
fn complete_interrupted_commit(out: &Path) -> Result<()> {
    match read_journal(out)? {
        Some(journal) => replay(out, &journal).map_err(|source| Error::io(out.join(COMMIT_JOURNAL), source)),
        None => Ok(()),
    }
}

/// The journal of an interrupted commit in `out`, if there is one, once every path it names is
/// known to stay inside the folder; a journal that names anything else (a damaged or hostile one)
/// is refused with the reason, and nothing is touched.
pub fn read_journal(out: &Path) -> Result<Option<Journal>> {
    let journal_path = out.join(COMMIT_JOURNAL);
    let Ok(metadata) = journal_path.symlink_metadata() else { return Ok(None) };
    let refused = |reason: String| {
        Error::format(
            &journal_path,
            format!(
                "{reason}; tmlut refuses this journal of an interrupted build and touches nothing: rebuild into a \
                 new folder, or remove the journal and rebuild every table"
            ),
        )
    };
    if !metadata.is_file() {
        return Err(refused("is not a plain file (a symbolic link or a folder)".into()));
    }
    let bytes = read_bytes_at_most(&journal_path, MAX_MANIFEST_BYTES, "a commit journal")?;
    let journal: Journal =
        serde_json::from_slice(&bytes).map_err(|e| refused(format!("not a tmlut commit journal: {e}")))?;
    check_journal(out, &journal).map_err(refused)?;
    Ok(Some(journal))
}

/// Whether every path `journal` names resolves inside `out` with no symbolic link on the way: the
/// staging folder (a `.tmlut-staging-` folder of `out`, not a link), every staged file (not a
/// link), every destination and removal (a file name of the folder or of one of its known
/// subfolders, which must be real folders).
fn check_journal(out: &Path, journal: &Journal) -> std::result::Result<(), String> {
    check_file_name(&journal.staging)?;
    if !journal.staging.starts_with(STAGING_PREFIX) {
        return Err(format!("`{}` is not a staging folder", journal.staging.escape_debug()));
    }
    let staging = out.join(&journal.staging);
    // A staging folder already removed is a commit whose renames are done.
    not_a_link(&staging)?;
    for m in &journal.moves {
        check_destination_name(&m.staged)?;
        check_destination_name(&m.destination)?;
        not_a_link_on_the_way(&staging, &m.staged)?;
        // A staged link would carry a file from outside into the folder.
        not_a_link(&staging.join(&m.staged))?;
        not_a_link_on_the_way(out, &m.destination)?;
    }
    for file in &journal.removals {
        check_destination_name(file)?;
        not_a_link_on_the_way(out, file)?;
    }
    Ok(())
}

/// The subfolder of `name` (a file name, or `subfolder/file`) under `dir` is not a symbolic link.
/// A file that is a link is replaced by a rename or removed as a link, never followed.
fn not_a_link_on_the_way(dir: &Path, name: &str) -> std::result::Result<(), String> {
    match name.split_once('/') {
        Some((subfolder, _)) => not_a_link(&dir.join(subfolder)),
        None => Ok(()),
    }
}

fn not_a_link(path: &Path) -> std::result::Result<(), String> {
    match path.symlink_metadata() {
        Ok(metadata) if metadata.file_type().is_symlink() => {
            Err(format!("`{}` is a symbolic link, which could lead outside the folder", path.display()))
        }
        _ => Ok(()),
    }
}

/// Remove staging folders and temporary files left by builds that died (the caller holds the
/// lock, so no live build owns them).
fn remove_abandoned(out: &Path) {
    let Ok(entries) = std::fs::read_dir(out) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(STAGING_PREFIX) {
            let _ = std::fs::remove_dir_all(entry.path());
        } else if is_temporary(&name) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Make the renames inside `dir` durable (a no-op where folders cannot be opened as files).
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::faults::{FAIL_AT, PASSED};
    use super::*;
    use crate::config::Config;
    use crate::loader::LutFolder;
    use crate::pipeline::{BuildRequest, build};
    use crate::report::check::{Budgets, check_folder};

    /// Karis and GD, a few hundred texels each.
    fn config(orientation: &str) -> Config {
        let text = format!(
            "[karis]\nmu_count = 8\nroughness_count = 6\norientation = \"{orientation}\"\n\
             [karis.sampling]\nsamples = 64\nreplicates = 4\n[karis.reference]\ncells = 2\nnodes = 8\n\
             [gd]\nmu_count = 5\nalpha_count = 5\n[gd.sampling]\nsamples = 64\nreplicates = 4\n\
             [gd.reference]\ncells = 2\nnodes = 8\n"
        );
        Config::from_toml(&text, "test").unwrap()
    }

    fn build_into(out: &Path, orientation: &str, only: &[&str], error_maps: bool) -> Result<()> {
        let only = Some(only.iter().map(|s| s.to_string()).collect());
        let request = BuildRequest { config: config(orientation), only, out: out.to_path_buf(), error_maps };
        build(&request, &()).map(|_| ())
    }

    /// Every file of the manifest loads, verified against its entry; returns the roughness of row 0
    /// of both Karis files (1 for rough-first), which must agree.
    fn verified_karis_row_0(out: &Path) -> f64 {
        let folder = LutFolder::open(out).unwrap();
        for file in folder.manifest().files.keys() {
            folder.load(file).unwrap_or_else(|e| panic!("{file}: {e}"));
        }
        let findings = check_folder(out, &Budgets::default()).unwrap();
        assert!(findings.iter().all(|f| f.pass), "{findings:?}");
        let starts: Vec<f64> = ["karis.dds", "karis.exr"]
            .iter()
            .map(|file| folder.manifest().entry(file).unwrap().axes[1].axis.start)
            .collect();
        assert_eq!(starts[0], starts[1], "karis.dds and karis.exr come from different builds");
        starts[0]
    }

    fn leftovers(out: &Path) -> Vec<String> {
        std::fs::read_dir(out)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect()
    }

    #[test]
    fn a_failure_anywhere_in_the_commit_leaves_old_new_or_a_journal_that_the_next_build_completes() {
        // The fault points of a whole commit: a new Karis (flipped, with error maps) over an old one.
        let dir = tempfile::tempdir().unwrap();
        build_into(dir.path(), "rough-first", &["karis", "gd"], false).unwrap();
        PASSED.with(|p| p.set(0));
        build_into(dir.path(), "smooth-first", &["karis"], true).unwrap();
        let points = PASSED.with(|p| p.get());
        assert!(points >= 8, "{points} fault points");
        assert_eq!(verified_karis_row_0(dir.path()), 0.0);

        let (mut old, mut journal) = (0, 0);
        for fail_at in 0..points {
            let dir = tempfile::tempdir().unwrap();
            let out = dir.path();
            build_into(out, "rough-first", &["karis", "gd"], false).unwrap();
            FAIL_AT.with(|f| f.set(Some(fail_at)));
            PASSED.with(|p| p.set(0));
            let failed = build_into(out, "smooth-first", &["karis"], true);
            FAIL_AT.with(|f| f.set(None));
            let error = failed.expect_err("the injected fault fails the build").to_string();
            assert!(error.contains("injected fault"), "{error}");

            let interrupted = pending_commit_exists(out);
            if interrupted {
                // The folder says so, to the loader and to check.
                journal += 1;
                let refused = LutFolder::open(out).unwrap_err().to_string();
                assert!(refused.contains("interrupted"), "{refused}");
                let findings = check_folder(out, &Budgets::default()).unwrap();
                assert!(findings.iter().any(|f| f.check == "commit" && !f.pass), "{findings:?}");
                assert!(error.contains("the next `tmlut build`"), "{error}");
            } else {
                // Wholly old: nothing of the new build is in place.
                old += 1;
                assert_eq!(verified_karis_row_0(out), 1.0, "fault {fail_at}: {error}");
                assert!(!out.join("maps").exists());
            }
            // Any next build repairs the folder: the interrupted commit is completed first.
            build_into(out, "rough-first", &["gd"], false).unwrap();
            let row_0 = verified_karis_row_0(out);
            assert_eq!(row_0, if interrupted { 0.0 } else { 1.0 }, "fault {fail_at}");
            assert!(leftovers(out).is_empty(), "fault {fail_at}: {:?}", leftovers(out));
        }
        // The journal is the commit point: before it the folder is wholly old, after it a journal
        // stands until the commit is complete.
        assert_eq!((old, journal), (1, points - 1), "{old} wholly old, {journal} with a journal, of {points}");
    }

    fn pending_commit_exists(out: &Path) -> bool {
        crate::formats::manifest::pending_commit(out).is_some()
    }

    #[test]
    fn everything_that_can_be_checked_is_checked_before_anything_moves() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        build_into(out, "rough-first", &["karis", "gd"], false).unwrap();
        let before = std::fs::read(out.join(MANIFEST_FILE)).unwrap();
        // A folder where the new build writes a file, and a file where it writes a folder.
        std::fs::remove_file(out.join("karis.exr")).unwrap();
        std::fs::create_dir(out.join("karis.exr")).unwrap();
        let error = build_into(out, "smooth-first", &["karis"], false).unwrap_err().to_string();
        assert!(error.contains("karis.exr") && error.contains("is a folder"), "{error}");
        std::fs::remove_dir(out.join("karis.exr")).unwrap();
        std::fs::write(out.join("maps"), b"x").unwrap();
        let error = build_into(out, "smooth-first", &["karis"], true).unwrap_err().to_string();
        assert!(error.contains("maps") && error.contains("is a file"), "{error}");
        assert_eq!(std::fs::read(out.join(MANIFEST_FILE)).unwrap(), before);
        assert!(leftovers(out).is_empty(), "{:?}", leftovers(out));
        assert!(out.join("karis.dds").exists() && !pending_commit_exists(out));

        // Two staged files of one name.
        let dir = tempfile::tempdir().unwrap();
        let folder = OutputFolder::take(dir.path(), |_| {}).unwrap();
        let mut staging = folder.staging().unwrap();
        let same = Move { staged: "a".into(), destination: "x.dds".into() };
        let error = commit(&folder, &mut staging, vec![same.clone(), same], Vec::new()).unwrap_err().to_string();
        assert!(error.contains("x.dds") && error.contains("two files"), "{error}");
        // Names that differ only in case are one file on a case-insensitive file system (the
        // default on macOS and Windows): refused as well, and so is the listing file's name.
        {
            let mut staging = folder.staging().unwrap();
            let upper = Move { staged: "b".into(), destination: "Copper_furnace.png".into() };
            let lower = Move { staged: "c".into(), destination: "copper_furnace.png".into() };
            let error = commit(&folder, &mut staging, vec![upper, lower], Vec::new()).unwrap_err().to_string();
            assert!(error.contains("copper_furnace.png") && error.contains("two files"), "{error}");
        }
        {
            let mut staging = folder.staging().unwrap();
            let listing = Move { staged: "d".into(), destination: "Furnace.json".into() };
            let error =
                commit_set(&folder, &mut staging, vec![listing], Vec::new(), "furnace.json").unwrap_err().to_string();
            assert!(error.contains("Furnace.json") && error.contains("two files"), "{error}");
        }
        drop(staging);
        assert!(leftovers(dir.path()).iter().all(|n| n == LOCK_FILE), "{:?}", leftovers(dir.path()));
    }

    #[test]
    fn an_output_path_that_is_a_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("luts");
        std::fs::write(&file, b"x").unwrap();
        let error = build_into(&file, "rough-first", &["gd"], false).unwrap_err().to_string();
        assert!(error.contains("luts") && error.contains("is a file"), "{error}");
    }

    #[test]
    fn a_table_built_again_leaves_no_file_of_its_earlier_build() {
        let dir = tempfile::tempdir().unwrap();
        build_into(dir.path(), "bottom-up-image", &["karis", "gd"], false).unwrap();
        assert!(dir.path().join("karis.exr").exists());
        // Karis again, in DDS only: its EXR file is an earlier build's and goes; GD stays.
        let mut config = config("bottom-up-image");
        config.karis.shared.output.formats = vec![crate::formats::FileFormat::Dds];
        let request =
            BuildRequest { config, only: Some(vec!["karis".into()]), out: dir.path().to_path_buf(), error_maps: false };
        build(&request, &()).unwrap();
        let folder = LutFolder::open(dir.path()).unwrap();
        let listed: Vec<&str> = folder.manifest().files.keys().map(String::as_str).collect();
        assert_eq!(listed, ["gd.dds", "karis.dds"]);
        assert!(!dir.path().join("karis.exr").exists());
        assert!(dir.path().join("gd.dds").exists());
        let findings = check_folder(dir.path(), &Budgets::default()).unwrap();
        assert!(findings.iter().all(|f| f.pass), "{findings:?}");
    }

    /// A folder with a build in it, a victim file beside it outside the folder, and a journal.
    fn folder_with_journal(journal: &serde_json::Value) -> (tempfile::TempDir, PathBuf, PathBuf) {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        build_into(&out, "rough-first", &["gd"], false).unwrap();
        let victim = root.path().join("victim");
        std::fs::write(&victim, b"not tmlut's").unwrap();
        std::fs::write(out.join(COMMIT_JOURNAL), serde_json::to_vec(journal).unwrap()).unwrap();
        (root, out, victim)
    }

    #[test]
    fn a_journal_naming_paths_outside_the_folder_is_refused_and_nothing_is_touched() {
        let root_of = |victim: &Path| victim.display().to_string();
        for removal in ["../victim", "ABSOLUTE", "maps/../../victim", "..", "maps/../../../victim"] {
            let (_root, out, victim) = folder_with_journal(&serde_json::json!({
                "staging": ".tmlut-staging-1", "moves": [], "removals": [],
            }));
            let removal = if removal == "ABSOLUTE" { root_of(&victim) } else { removal.to_string() };
            let journal = serde_json::json!({ "staging": ".tmlut-staging-1", "moves": [], "removals": [removal] });
            std::fs::write(out.join(COMMIT_JOURNAL), serde_json::to_vec(&journal).unwrap()).unwrap();
            let manifest = std::fs::read(out.join(MANIFEST_FILE)).unwrap();
            let error = build_into(&out, "rough-first", &["gd"], false).unwrap_err().to_string();
            assert!(error.contains("refuses this journal"), "{removal}: {error}");
            assert!(victim.exists(), "{removal}: the file outside the folder was removed");
            assert!(out.join(COMMIT_JOURNAL).exists() && out.join("gd.dds").exists());
            assert_eq!(std::fs::read(out.join(MANIFEST_FILE)).unwrap(), manifest);
            // check says the journal is refused, not that a build would complete it.
            let findings = check_folder(&out, &Budgets::default()).unwrap();
            let commit = findings.iter().find(|f| f.check == "commit").unwrap();
            assert!(!commit.pass && commit.value.contains("refuses"), "{}", commit.value);
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_journal_leading_through_a_symbolic_link_is_refused_and_nothing_is_touched() {
        use std::os::unix::fs::symlink;
        // A staging folder that is a link to a folder outside: its file would be moved in.
        let (root, out, victim) = folder_with_journal(&serde_json::json!({
            "staging": ".tmlut-staging-7",
            "moves": [{ "staged": "victim", "destination": "taken.dds" }],
        }));
        symlink(root.path(), out.join(".tmlut-staging-7")).unwrap();
        let error = build_into(&out, "rough-first", &["gd"], false).unwrap_err().to_string();
        assert!(error.contains("symbolic link") && error.contains("refuses"), "{error}");
        assert!(victim.exists() && !out.join("taken.dds").exists());

        // A staged file that is a link to a file outside.
        let (_root, out, victim) = folder_with_journal(&serde_json::json!({
            "staging": ".tmlut-staging-7",
            "moves": [{ "staged": "link", "destination": "taken.dds" }],
        }));
        std::fs::create_dir(out.join(".tmlut-staging-7")).unwrap();
        symlink(&victim, out.join(".tmlut-staging-7/link")).unwrap();
        let error = build_into(&out, "rough-first", &["gd"], false).unwrap_err().to_string();
        assert!(error.contains("symbolic link"), "{error}");
        assert!(!out.join("taken.dds").exists());

        // A subfolder that is a link: a removal under it would delete outside.
        let (root, out, victim) = folder_with_journal(&serde_json::json!({
            "staging": ".tmlut-staging-7", "moves": [], "removals": ["maps/victim"],
        }));
        symlink(root.path(), out.join("maps")).unwrap();
        let error = build_into(&out, "rough-first", &["gd"], false).unwrap_err().to_string();
        assert!(error.contains("symbolic link"), "{error}");
        assert!(victim.exists());

        // The journal itself a link.
        let (root, out, victim) = folder_with_journal(&serde_json::json!({}));
        std::fs::remove_file(out.join(COMMIT_JOURNAL)).unwrap();
        std::fs::write(
            root.path().join("j.json"),
            br#"{"staging":".tmlut-staging-1","moves":[],"removals":["victim"]}"#,
        )
        .unwrap();
        symlink(root.path().join("j.json"), out.join(COMMIT_JOURNAL)).unwrap();
        let error = build_into(&out, "rough-first", &["gd"], false).unwrap_err().to_string();
        assert!(error.contains("not a plain file"), "{error}");
        assert!(victim.exists());
    }

    #[test]
    fn a_valid_journal_with_removals_inside_the_folder_is_still_completed() {
        let (_root, out, victim) = folder_with_journal(&serde_json::json!({
            "staging": ".tmlut-staging-3", "moves": [], "removals": ["stale.dds"],
        }));
        std::fs::write(out.join("stale.dds"), b"old").unwrap();
        build_into(&out, "rough-first", &["gd"], false).unwrap();
        assert!(!out.join("stale.dds").exists() && !pending_commit_exists(&out) && victim.exists());
    }

    /// Journals drawn from hostile path pieces (absolute paths, `..`, subfolders, links, names of
    /// files outside), 300 of them: taking the folder either completes a journal or refuses it,
    /// and never touches a file outside the folder.
    #[cfg(unix)]
    #[test]
    fn fuzzed_journals_never_touch_a_file_outside_the_folder() {
        use std::os::unix::fs::symlink;
        let root = tempfile::tempdir().unwrap();
        let outside = root.path().join("outside");
        std::fs::create_dir(&outside).unwrap();
        let victim = outside.join("victim");
        let pieces: Vec<String> = vec![
            "victim".into(),
            "../outside/victim".into(),
            "../../victim".into(),
            victim.display().to_string(),
            "maps/victim".into(),
            "maps/../../outside/victim".into(),
            "link".into(),
            "link/victim".into(),
            ".tmlut-staging-1".into(),
            ".tmlut-staging-1/../../outside/victim".into(),
            "".into(),
            ".".into(),
            "..".into(),
            "gd.dds".into(),
            "C:victim".into(),
            "a\\..\\..\\victim".into(),
        ];
        // xorshift64: a fixed sequence of draws below `n`.
        let state = std::cell::Cell::new(0x9E37_79B9_7F4A_7C15u64);
        let draw = |n: usize| {
            let mut x = state.get();
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            state.set(x);
            (x % n as u64) as usize
        };
        for case in 0..300 {
            let out = root.path().join(format!("out{case}"));
            std::fs::create_dir(&out).unwrap();
            std::fs::write(&victim, b"not tmlut's").unwrap();
            // Links a hostile folder may hold: a staging folder, a subfolder, a file.
            if draw(2) == 0 {
                symlink(&outside, out.join(".tmlut-staging-1")).unwrap();
            } else {
                std::fs::create_dir(out.join(".tmlut-staging-1")).unwrap();
                if draw(2) == 0 {
                    symlink(&victim, out.join(".tmlut-staging-1/victim")).unwrap();
                }
            }
            if draw(2) == 0 {
                symlink(&outside, out.join("maps")).unwrap();
            }
            if draw(2) == 0 {
                symlink(&outside, out.join("link")).unwrap();
            }
            let piece = || pieces[draw(pieces.len())].clone();
            let moves: Vec<serde_json::Value> =
                (0..draw(3)).map(|_| serde_json::json!({ "staged": piece(), "destination": piece() })).collect();
            let removals: Vec<String> = (0..draw(3)).map(|_| piece()).collect();
            let staging = if draw(4) == 0 { piece() } else { ".tmlut-staging-1".to_string() };
            let journal = serde_json::json!({ "staging": staging, "moves": moves, "removals": removals });
            std::fs::write(out.join(COMMIT_JOURNAL), serde_json::to_vec(&journal).unwrap()).unwrap();
            let taken = OutputFolder::take(&out, |_| {});
            assert_eq!(std::fs::read(&victim).ok().as_deref(), Some(&b"not tmlut's"[..]), "case {case}: {journal}");
            assert_eq!(std::fs::read_dir(&outside).unwrap().count(), 1, "case {case}: {journal}");
            if let Err(e) = taken {
                let said = e.to_string();
                assert!(said.contains("journal") || said.contains(COMMIT_JOURNAL), "case {case}: {said}");
            }
        }
    }
}
