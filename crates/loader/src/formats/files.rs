//! How tmlut meets the file system at its edges.
//!
//! - **Inputs** are opened without waiting ([`open_regular`]: a FIFO opened the plain way blocks
//!   until a writer comes, which may be never) and refused unless they are regular files of at
//!   most a stated size, before anything is allocated for them.
//! - **Outputs** are created exclusively (`O_EXCL`: a name that exists, a symbolic link
//!   included, is never opened) under names no other process can predict
//!   ([`create_temporary`]), then renamed into place ([`write_atomically`]). A rename replaces
//!   whatever the destination name held, a link as a link, and never writes into an existing
//!   file, so a link or a hard link planted under a name tmlut uses leads nowhere.
//! - **The one file written in place**, an output folder's lock, is opened never through a link
//!   and refused unless it is a regular file of one link ([`open_lock_file`]).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// What a path names, in words, for an error: "a folder", "a FIFO", ...
fn kind_of(metadata: &std::fs::Metadata) -> &'static str {
    let file_type = metadata.file_type();
    if file_type.is_dir() {
        return "a folder";
    }
    if file_type.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_socket() {
            return "a socket";
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return "a device";
        }
    }
    "not a regular file"
}

/// Open `path` for reading as a regular file, with its length. A FIFO, a device, a socket or a
/// folder is refused naming what it is; `what` names the kind of input in the error.
pub fn open_regular(path: &Path, what: &str) -> Result<(File, u64)> {
    let mut options = OpenOptions::new();
    options.read(true);
    // Opening a FIFO for reading waits for a writer unless O_NONBLOCK is set; a regular file
    // reads the same either way.
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|source| Error::io(path, source))?;
    let metadata = file.metadata().map_err(|source| Error::io(path, source))?;
    if !metadata.is_file() {
        return Err(Error::format(path, format!("is {}; {what} must be a regular file", kind_of(&metadata))));
    }
    Ok((file, metadata.len()))
}

/// Read a whole regular file of at most `limit` bytes; `what` names the kind of file in the error.
///
/// A device, a pipe or a folder is refused before reading ([`open_regular`]), and so is a file
/// longer than `limit`; a file that grows while it is read stops at `limit + 1` bytes and is
/// refused too, so that no input makes tmlut allocate more than its limit. The buffer is reserved
/// fallibly: a file this process has no memory for is an error naming its size, not an abort.
pub fn read_bytes_at_most(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let (file, length) = open_regular(path, what)?;
    let too_long =
        |length: u64| Error::format(path, format!("is {length} bytes long; {what} may be at most {limit} bytes"));
    if length > limit {
        return Err(too_long(length));
    }
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(length as usize).map_err(|_| {
        Error::format(path, format!("is {length} bytes long, more than this process can allocate to read it"))
    })?;
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|source| Error::io(path, source))?;
    if bytes.len() as u64 > limit {
        return Err(too_long(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Refuse to read `path` where its length is at least `from` bytes and `factor` times it is more
/// memory than this process may use ([`crate::memory::beyond_limit`]): what reading it, and
/// decoding or parsing what was read, takes. Below `from` the limit is not read at all.
pub fn hold_to_memory(path: &Path, from: u64, factor: u128, what: &str) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(metadata) if metadata.len() >= from => {
            match crate::memory::beyond_limit(factor * u128::from(metadata.len()), what) {
                Some(words) => Err(Error::format(path, words)),
                None => Ok(()),
            }
        }
        _ => Ok(()),
    }
}

/// Read a UTF-8 text file of at most `limit` bytes (see [`read_bytes_at_most`]).
pub fn read_text_at_most(path: &Path, limit: u64, what: &str) -> Result<String> {
    let bytes = read_bytes_at_most(path, limit, what)?;
    String::from_utf8(bytes).map_err(|e| {
        Error::format(
            path,
            format!("is not UTF-8 text (invalid byte at offset {}); {what} is text", e.utf8_error().valid_up_to()),
        )
    })
}

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

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_at_once_rather_than_waited_on() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("manifest.json");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        let refused = read_bytes_at_most(&fifo, 1 << 20, "a manifest").unwrap_err().to_string();
        assert!(refused.contains("FIFO") && refused.contains("regular file"), "{refused}");
        let refused = read_bytes_at_most(Path::new("/dev/zero"), 1 << 20, "a scene").unwrap_err().to_string();
        assert!(refused.contains("a device"), "{refused}");
        let refused = read_bytes_at_most(dir.path(), 1 << 20, "a scene").unwrap_err().to_string();
        assert!(refused.contains("a folder"), "{refused}");
    }
}
