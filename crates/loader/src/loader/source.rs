//! Where a set of tables' files come from: a folder on disk ([`OnDisk`]), files held in memory
//! ([`InMemory`]: an asset pipeline's, an archive's, a web page's downloads), or anything else
//! that hands over a file's bytes by its name (an implementation of [`LutSource`]).
//! [`LutFolder::from_source`](super::LutFolder::from_source) reads the manifest and every file
//! through one and verifies each as a folder's: each file within its kind's limit, then against its
//! entry (length, SHA-256, sealed claims, axes, channels, value range), with the same errors.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::formats::files::FileKind;

/// A set of files by name: what a [`LutFolder`](super::LutFolder) reads its manifest, tables and
/// shaders from.
///
/// An implementation hands over bytes; the checks are the folder's. It is asked only for plain
/// file names (one path component, no `..`), each once per load.
pub trait LutSource: std::fmt::Debug + Send + Sync {
    /// The path errors name the set by: a folder's own, or the name the set was given. Its file
    /// `file` is named `root/file`.
    fn root(&self) -> &Path;

    /// The bytes of the file `file`, of `kind`. A set without such a file answers
    /// [`Error::Io`] of kind [`std::io::ErrorKind::NotFound`]. One that reads them from somewhere
    /// refuses a file longer than [`FileKind::limit`] before reading it; bytes over the limit are
    /// refused however they came.
    fn read(&self, file: &str, kind: FileKind) -> Result<Cow<'_, [u8]>>;

    /// Whether the set holds a file named `file`: a pending commit's journal, which makes a folder
    /// unfinished.
    fn contains(&self, file: &str) -> bool;
}

/// The files of a folder on disk: each read whole, refused unless a regular file within its
/// kind's limit and, where large, unless this process may use what decoding it takes
/// ([`FileKind::read`]).
#[derive(Debug, Clone)]
pub struct OnDisk {
    dir: PathBuf,
}

impl OnDisk {
    /// The folder `dir`.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        OnDisk { dir: dir.into() }
    }
}

impl LutSource for OnDisk {
    fn root(&self) -> &Path {
        &self.dir
    }

    fn read(&self, file: &str, kind: FileKind) -> Result<Cow<'_, [u8]>> {
        kind.read(&self.dir.join(file)).map(Cow::Owned)
    }

    /// Whether a file, folder or link of that name is there.
    fn contains(&self, file: &str) -> bool {
        self.dir.join(file).symlink_metadata().is_ok()
    }
}

/// Files held in memory, by name: a folder's files as an asset pipeline, an archive or a
/// download hands them over. Each is borrowed where it is read, never copied.
#[derive(Clone, Default)]
pub struct InMemory {
    root: PathBuf,
    files: BTreeMap<String, Cow<'static, [u8]>>,
}

impl InMemory {
    /// No file yet; errors name the set's files `root/file` (where they came from: an archive's
    /// path, a URL).
    pub fn new(root: impl Into<PathBuf>) -> Self {
        InMemory { root: root.into(), files: BTreeMap::new() }
    }

    /// The set with the file `name` holding `bytes`: owned (`Vec<u8>`) or borrowed for the
    /// program's life (`include_bytes!`).
    pub fn with(mut self, name: impl Into<String>, bytes: impl Into<Cow<'static, [u8]>>) -> Self {
        self.insert(name, bytes);
        self
    }

    /// Hold `bytes` as the file `name`, in place of any held under that name.
    pub fn insert(&mut self, name: impl Into<String>, bytes: impl Into<Cow<'static, [u8]>>) {
        self.files.insert(name.into(), bytes.into());
    }
}

impl std::fmt::Debug for InMemory {
    /// The root and each file's name and length, not its bytes.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let lengths: BTreeMap<&str, usize> =
            self.files.iter().map(|(name, bytes)| (name.as_str(), bytes.len())).collect();
        f.debug_struct("InMemory").field("root", &self.root).field("file_lengths", &lengths).finish()
    }
}

impl LutSource for InMemory {
    fn root(&self) -> &Path {
        &self.root
    }

    fn read(&self, file: &str, _kind: FileKind) -> Result<Cow<'_, [u8]>> {
        let bytes = self.files.get(file).ok_or_else(|| {
            let absent = std::io::Error::new(std::io::ErrorKind::NotFound, "no file of this name is held in memory");
            Error::io(self.root.join(file), absent)
        })?;
        Ok(Cow::Borrowed(bytes.as_ref()))
    }

    fn contains(&self, file: &str) -> bool {
        self.files.contains_key(file)
    }
}
