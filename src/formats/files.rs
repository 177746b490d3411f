//! How tmlut meets the file system with its outputs; the inputs' side is the loader's
//! (`tmlut_loader::formats::files`), re-exported here.
//!
//! - **Outputs** are created exclusively (`O_EXCL`: a name that exists, a symbolic link
//!   included, is never opened) under names no other process can predict
//!   ([`create_temporary`]), then renamed into place ([`write_atomically`]). A rename replaces
//!   whatever the destination name held, a link as a link, and never writes into an existing
//!   file, so a link or a hard link planted under a name tmlut uses leads nowhere.
//! - **The one file written in place**, an output folder's lock, is opened never through a link
//!   and refused unless it is a regular file of one link ([`open_lock_file`]).

pub use tmlut_loader::formats::files::*;

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Sixteen hexadecimal digits no other process can predict: SipHash under the random key of a
/// fresh `RandomState` (seeded from the operating system's randomness), of a counter, the
/// process and the time.
pub fn unpredictable_name() -> String {
    use std::hash::{BuildHasher, Hasher};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    hasher.write_u32(std::process::id());
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    hasher.write_u128(now.as_nanos());
    format!("{:016x}", hasher.finish())
}

/// Create the file `path` for writing, only if no file, folder or link has that name. POSIX
/// `O_CREAT | O_EXCL` fails on a symbolic link at the path, dangling or not, rather than follow it.
pub fn create_new(path: &Path) -> std::io::Result<File> {
    OpenOptions::new().write(true).create_new(true).open(path)
}

/// The marker of a temporary file's name: `.<name>.tmp-<16 hex digits>` (see [`is_temporary`]).
pub const TEMPORARY_MARKER: &str = ".tmp-";

/// Whether `name` is the name [`create_temporary`] gives.
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(TEMPORARY_MARKER)
}

/// Create a temporary file in `dir` for the file `name`: `.<name>.tmp-<unpredictable>`, created
/// exclusively ([`create_new`]); a name taken (by chance, or planted) is passed over for another.
pub fn create_temporary(dir: &Path, name: &str) -> std::io::Result<(PathBuf, File)> {
    let mut last = None;
    for _ in 0..16 {
        let path = dir.join(format!(".{name}{TEMPORARY_MARKER}{}", unpredictable_name()));
        match create_new(&path) {
            Ok(file) => return Ok((path, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| std::io::Error::other("no free temporary name")))
}

/// Write a file through a temporary sibling ([`create_temporary`]) and an atomic rename. The
/// temporary file is removed if writing fails.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file_name =
        path.file_name().ok_or_else(|| Error::invalid("output path", format!("{} names no file", path.display())))?;
    let (temporary, file) =
        create_temporary(dir, &file_name.to_string_lossy()).map_err(|source| Error::io(path, source))?;
    let result = (|| {
        let mut writer = BufWriter::new(file);
        write(&mut writer)?;
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()
    })();
    if let Err(source) = result {
        let _ = std::fs::remove_file(&temporary);
        return Err(Error::io(path, source));
    }
    std::fs::rename(&temporary, path).map_err(|source| {
        let _ = std::fs::remove_file(&temporary);
        Error::io(path, source)
    })
}

/// Write a byte buffer atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(bytes))
}

/// Open (creating it if missing) the lock file `path` of a folder, to read and write in place: a
/// symbolic link at the path is refused, not followed (`O_NOFOLLOW`), and so is anything but a
/// regular file of one link (a hard link would make the lock's writes land in another file).
pub fn open_lock_file(path: &Path) -> Result<File> {
    let mut options = OpenOptions::new();
    options.read(true).write(true).create(true).truncate(false);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let refused = |what: &str| {
        Error::format(
            path,
            format!(
                "is {what}; tmlut writes its lock file only as a regular file of its own and never through a link: \
                 remove it"
            ),
        )
    };
    let file = match options.open(path) {
        Ok(file) => file,
        Err(source) => {
            return Err(match path.symlink_metadata() {
                Ok(metadata) if metadata.file_type().is_symlink() => refused("a symbolic link"),
                _ => Error::io(path, source),
            });
        }
    };
    let metadata = file.metadata().map_err(|source| Error::io(path, source))?;
    if !metadata.is_file() {
        return Err(refused(kind_of(&metadata)));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if metadata.nlink() != 1 {
            return Err(refused(&format!("a file of {} hard links", metadata.nlink())));
        }
    }
    Ok(file)
}

/// Create the folder `path` inside a folder tmlut was given, or accept the folder already there;
/// a symbolic link there (to a folder or not) is refused, not followed.
pub fn create_folder_inside(path: &Path) -> Result<()> {
    match std::fs::create_dir(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            let metadata = path.symlink_metadata().map_err(|source| Error::io(path, source))?;
            if metadata.is_dir() {
                Ok(())
            } else {
                Err(Error::format(
                    path,
                    format!("is {} where tmlut writes a folder; it never writes through a link", kind_of(&metadata)),
                ))
            }
        }
        Err(source) => Err(Error::io(path, source)),
    }
}

/// Create the folder `base/relative` for tmlut's own use: `base`, a folder tmlut was given, is
/// created if missing (a link the user named there is theirs to name), and each component of
/// `relative` below it by [`create_folder_inside`], so that a link planted there is refused.
pub fn create_folders_inside(base: &Path, relative: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(base).map_err(|source| Error::io(base, source))?;
    let mut path = base.to_path_buf();
    for component in relative.components() {
        match component {
            std::path::Component::Normal(name) => path.push(name),
            other => {
                return Err(Error::invalid(
                    "output folder",
                    format!("`{}` is not a plain name ({other:?}) inside {}", relative.display(), base.display()),
                ));
            }
        }
        create_folder_inside(&path)?;
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporaries_are_created_exclusively_under_names_no_one_can_predict() {
        let dir = tempfile::tempdir().unwrap();
        let names: std::collections::BTreeSet<String> = (0..1000).map(|_| unpredictable_name()).collect();
        assert_eq!(names.len(), 1000);
        let (path, _) = create_temporary(dir.path(), "a.dds").unwrap();
        let name = path.file_name().unwrap().to_str().unwrap();
        assert!(is_temporary(name) && name.starts_with(".a.dds.tmp-"), "{name}");
        // A second creation under the name fails rather than open the file again.
        assert_eq!(create_new(&path).unwrap_err().kind(), std::io::ErrorKind::AlreadyExists);
    }

    #[cfg(unix)]
    #[test]
    fn links_planted_under_an_output_name_are_replaced_never_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, b"not tmlut's").unwrap();
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&victim, out.join("gd.dds")).unwrap();
        std::fs::hard_link(&victim, out.join("karis.dds")).unwrap();
        write_bytes_atomically(&out.join("gd.dds"), b"table").unwrap();
        write_bytes_atomically(&out.join("karis.dds"), b"table").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"not tmlut's");
        assert_eq!(std::fs::read(out.join("gd.dds")).unwrap(), b"table");
        assert!(!out.join("gd.dds").symlink_metadata().unwrap().file_type().is_symlink());
        // A link where the created file goes: O_EXCL refuses it, dangling or not.
        std::os::unix::fs::symlink(dir.path().join("nowhere"), out.join("dangling")).unwrap();
        assert!(create_new(&out.join("dangling")).is_err());
        assert!(!dir.path().join("nowhere").exists());

        // The lock file: neither a link nor a hard link is opened.
        std::os::unix::fs::symlink(&victim, out.join(".lock")).unwrap();
        let refused = open_lock_file(&out.join(".lock")).unwrap_err().to_string();
        assert!(refused.contains("symbolic link"), "{refused}");
        std::fs::hard_link(&victim, out.join(".lock2")).unwrap();
        let refused = open_lock_file(&out.join(".lock2")).unwrap_err().to_string();
        assert!(refused.contains("hard links"), "{refused}");
        assert!(open_lock_file(&out.join(".lock3")).is_ok());
        assert_eq!(std::fs::read(&victim).unwrap(), b"not tmlut's");

        // A folder inside: a link there is refused.
        std::os::unix::fs::symlink(dir.path(), out.join("maps")).unwrap();
        assert!(create_folder_inside(&out.join("maps")).unwrap_err().to_string().contains("symbolic link"));
        create_folder_inside(&out.join("real")).unwrap();
        create_folder_inside(&out.join("real")).unwrap();
        assert!(create_folders_inside(&out, Path::new("maps/x")).is_err());
        assert!(!dir.path().join("x").exists());
        assert_eq!(create_folders_inside(&out, Path::new("a/b")).unwrap(), out.join("a/b"));
        assert!(create_folders_inside(&out, Path::new("../c")).is_err());
    }
}
