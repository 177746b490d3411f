//! How the readers meet the file system: inputs are opened without waiting ([`open_regular`]: a
//! FIFO opened the plain way blocks until a writer comes, which may be never) and refused unless
//! they are regular files of at most a stated size, before anything is allocated for them. How
//! tmlut creates its outputs (exclusively, under unpredictable names, renamed into place) is the
//! writing side's, tmlut's `formats::files`.

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::Path;

use super::{MAX_MANIFEST_BYTES, MAX_SHADER_FILE_BYTES, MAX_TABLE_FILE_BYTES};
use crate::error::{Error, Result};

/// What a path names, in words, for an error: "a folder", "a FIFO", ... (the writing side names
/// what it refuses to write through the same way).
#[doc(hidden)]
pub fn kind_of(metadata: &std::fs::Metadata) -> &'static str {
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
    if length > limit {
        return Err(too_long(path, length, limit, what));
    }
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(length as usize).map_err(|_| {
        Error::format(path, format!("is {length} bytes long, more than this process can allocate to read it"))
    })?;
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|source| Error::io(path, source))?;
    if bytes.len() as u64 > limit {
        return Err(too_long(path, bytes.len() as u64, limit, what));
    }
    Ok(bytes)
}

/// The error of an input `path` of `length` bytes, longer than the `limit` of `what` it is.
fn too_long(path: &Path, length: u64, limit: u64, what: &str) -> Error {
    Error::format(path, format!("is {length} bytes long; {what} may be at most {limit} bytes"))
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

/// The kinds of file a folder of tables holds, each read within its own limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FileKind {
    /// `manifest.json`.
    Manifest,
    /// A table file.
    Table,
    /// A shader file a manifest lists.
    Shader,
}

impl FileKind {
    /// The longest file of this kind a reader takes: [`MAX_MANIFEST_BYTES`],
    /// [`MAX_TABLE_FILE_BYTES`] or [`MAX_SHADER_FILE_BYTES`].
    pub fn limit(self) -> u64 {
        match self {
            FileKind::Manifest => MAX_MANIFEST_BYTES,
            FileKind::Table => MAX_TABLE_FILE_BYTES,
            FileKind::Shader => MAX_SHADER_FILE_BYTES,
        }
    }

    /// The kind in words, for errors: `a manifest`, `a table file`, `a shader file`.
    pub fn what(self) -> &'static str {
        match self {
            FileKind::Manifest => "a manifest",
            FileKind::Table => "a table file",
            FileKind::Shader => "a shader file",
        }
    }

    /// Read the file at `path` as this kind ([`read_bytes_at_most`] within [`FileKind::limit`]).
    ///
    /// A large manifest or table is first held to the memory this process may use
    /// ([`crate::memory::beyond_limit`]), so that a reader under a memory limit refuses it rather
    /// than abort on the allocation: a manifest from 16 MiB to six times its length (parsed, it
    /// takes about four times its text: `tmlut check` of the largest library's, 89 MB, peaked at
    /// 387 MB), a table from 64 MiB to three times (read whole, then decoded to f32 values: an
    /// f16 file's values double).
    pub fn read(self, path: &Path) -> Result<Vec<u8>> {
        match self {
            FileKind::Manifest => hold_to_memory(path, 16 << 20, 6, "reading it")?,
            FileKind::Table => hold_to_memory(path, 64 << 20, 3, "reading and decoding it")?,
            FileKind::Shader => {}
        }
        read_bytes_at_most(path, self.limit(), self.what())
    }

    /// Refuse `length` bytes of the file `path` of this kind where more than [`FileKind::limit`]:
    /// bytes that came some other way than [`FileKind::read`], with its error.
    pub fn check_length(self, path: &Path, length: usize) -> Result<()> {
        match length as u64 > self.limit() {
            true => Err(too_long(path, length as u64, self.limit(), self.what())),
            false => Ok(()),
        }
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

#[cfg(test)]
mod tests {
    use super::*;

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
