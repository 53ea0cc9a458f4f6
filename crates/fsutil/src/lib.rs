//! The one way octowrap writes a file: [`write_file`].
//!
//! A writer must never harm what it replaces. [`write_file`] decides by what the output path names:
//!
//! * **nothing, or a regular file** (possibly through symbolic links): the bytes go to a temporary
//!   file in the target's folder (`.octowrap-XXXXXX.tmp`), which is flushed, synced to disk, and
//!   renamed over the target; the folder is synced too. A reader sees the old file or the new one,
//!   never half of one. A symbolic link is followed to its final target, and that target is
//!   replaced: the link stays a link. A replaced file keeps its permission bits and, when the
//!   process may set them, its owner and group; a new file gets `0o666` less the umask, as any
//!   program's `open(O_CREAT)` does.
//! * **a FIFO, a character or block device, or a path under `/dev` or `/proc`** (`/dev/stdout`,
//!   `/dev/null`, `/proc/self/fd/1`): the bytes are written into it directly. Renaming over such
//!   a path would put a regular file where the pipe or device was.
//! * **a folder**: an error.
//!
//! Temporaries alive at any moment are listed in a registry, so that a process stopped by a
//! signal can remove them first: [`remove_temporaries_before_exit`].
//!
//! A path ending in `.gz` holds what the caller writes gzip-compressed when written with
//! [`write_file_gz`] (every command's output goes through it).
//!
//! [`check_output`] runs the same checks before any work is done (a long computation should not
//! end in "cannot write there"), and [`same_file`] tells whether two paths name one file (by
//! device and inode, so through symbolic and hard links), so that a command can refuse to
//! overwrite its own input.

#![deny(missing_docs)]

use std::fs::{File, Metadata, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

/// How to write. Build it with [`WriteOptions::default`] and set fields.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct WriteOptions {
    /// Refuse to replace an existing regular file (FIFOs and devices are written into, not
    /// replaced, so they are still accepted). Default false.
    pub no_clobber: bool,
}

impl WriteOptions {
    /// Options refusing to replace existing files when `no_clobber` is true.
    pub fn no_clobber(no_clobber: bool) -> Self {
        Self { no_clobber }
    }
}

/// Why [`write_file`] failed: the file system refused, or the caller's writer failed.
#[derive(Debug)]
pub enum WriteError<E> {
    /// Creating, syncing or renaming the file failed (the message says which step).
    Io(io::Error),
    /// The caller's writer returned this error; nothing was put in place of the target.
    Write(E),
}

impl<E: std::fmt::Display> std::fmt::Display for WriteError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io(e) => e.fmt(f),
            Self::Write(e) => e.fmt(f),
        }
    }
}

impl<E: std::error::Error + 'static> std::error::Error for WriteError<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io(e) => e.source(),
            Self::Write(e) => e.source(),
        }
    }
}

/// Most symbolic links followed from the output path (as Linux's `MAXSYMLINKS`).
const MAX_LINKS: usize = 40;

/// What an output path names.
enum Target {
    /// A regular file or nothing: replaced (or created) through a temporary beside `path`, the
    /// final target of any symbolic links. `existing` is the file's metadata when it exists.
    Replace { path: PathBuf, existing: Option<Metadata> },
    /// A FIFO, a device or a path under `/dev` or `/proc`: written into directly.
    Direct { truncate: bool },
}

/// Where writing to `path` would go, with `opts`' refusals.
fn target(path: &Path, opts: &WriteOptions) -> io::Result<Target> {
    let special_tree = path.starts_with("/dev") || path.starts_with("/proc");
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(io::Error::new(io::ErrorKind::IsADirectory, "is a folder, not a file")),
        Ok(m) if m.is_file() && opts.no_clobber => Err(exists()),
        Ok(m) if !m.is_file() || special_tree => Ok(Target::Direct { truncate: m.is_file() }),
        Ok(m) => Ok(Target::Replace { path: final_target(path)?, existing: Some(m) }),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            let path = final_target(path)?;
            Ok(Target::Replace { path, existing: None })
        }
        Err(e) => Err(e),
    }
}

fn exists() -> io::Error {
    io::Error::new(io::ErrorKind::AlreadyExists, "exists, and replacing files is turned off (no-clobber)")
}

/// `path` with every symbolic link along the last component followed (the target of a dangling
/// link is where the file is created).
fn final_target(path: &Path) -> io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&p)?;
                p = match p.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            Ok(_) => return Ok(p),
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(p),
            Err(e) => return Err(e),
        }
    }
    Err(io::Error::other(format!("more than {MAX_LINKS} symbolic links to follow")))
}

/// Checks, before any work, that [`write_file`] with `opts` could write `path`: it is not a
/// folder, its folder exists, and with `no_clobber` no regular file is there.
pub fn check_output(path: &Path, opts: &WriteOptions) -> io::Result<()> {
    if let Target::Replace { path, .. } = target(path, opts)? {
        let dir = folder(&path);
        if !dir.is_dir() {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("the folder {} does not exist", dir.display()),
            ));
        }
    }
    Ok(())
}

/// Whether `a` and `b` name the same existing regular file (same device and inode: through
/// symbolic links and hard links too). FIFOs and devices are not files a command overwrites with
/// its own input, so they never count (`/dev/stdin` and `/dev/stdout` are one terminal).
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else { return false };
    ma.is_file() && mb.is_file() && same_inode(&ma, &mb)
}

#[cfg(unix)]
fn same_inode(a: &Metadata, b: &Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_inode(_: &Metadata, _: &Metadata) -> bool {
    false
}

fn folder(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `path` with the bytes `write` produces (see the crate docs for what happens with each
/// kind of path). `write` gets a buffered writer; when it fails, the target is left as it was
/// (a FIFO or device has then received part of the output).
pub fn write_file<E>(
    path: &Path,
    opts: &WriteOptions,
    write: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), WriteError<E>> {
    match target(path, opts).map_err(WriteError::Io)? {
        Target::Direct { truncate } => {
            let file = OpenOptions::new().write(true).truncate(truncate).open(path).map_err(WriteError::Io)?;
            let mut w = BufWriter::with_capacity(1 << 20, file);
            write(&mut w).map_err(WriteError::Write)?;
            w.flush().map_err(WriteError::Io)
        }
        Target::Replace { path, existing } => replace(&path, existing.as_ref(), opts, write),
    }
}

/// Whether `path` ends in `.gz` (any case): [`write_file_gz`] compresses what goes there.
pub fn is_gz(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// `path` without a trailing `.gz` (as [`is_gz`] tells it), else `path` itself: the name whose
/// extension says what the file holds.
pub fn without_gz(path: &Path) -> PathBuf {
    if is_gz(path) { path.with_extension("") } else { path.to_path_buf() }
}

/// [`write_file`], gzip-compressing the bytes `write` produces when `path` ends in `.gz`.
pub fn write_file_gz<E>(
    path: &Path,
    opts: &WriteOptions,
    write: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), WriteError<E>> {
    if !is_gz(path) {
        return write_file(path, opts, write);
    }
    let compressed = |w: &mut dyn Write| -> Result<(), WriteError<E>> {
        let mut z = flate2::write::GzEncoder::new(w, flate2::Compression::default());
        write(&mut z).map_err(WriteError::Write)?;
        z.finish().map(drop).map_err(WriteError::Io)
    };
    write_file(path, opts, compressed).map_err(|e| match e {
        WriteError::Io(e) | WriteError::Write(WriteError::Io(e)) => WriteError::Io(e),
        WriteError::Write(WriteError::Write(e)) => WriteError::Write(e),
    })
}

/// The live temporaries (created, not yet renamed into place or removed).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes every temporary file a [`write_file`] in progress has created, and keeps any further
/// one from being created or renamed into place: call it only right before the process exits
/// (from a SIGINT or SIGTERM handler), since every write in progress then blocks.
pub fn remove_temporaries_before_exit() {
    let live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
    for p in live.iter() {
        let _ = std::fs::remove_file(p);
    }
    // Held until the process exits: no write may create or rename a temporary after this.
    std::mem::forget(live);
}

/// Unlists a temporary when dropped (the file itself is removed by `tempfile` unless persisted).
struct Listed(PathBuf);

impl Drop for Listed {
    fn drop(&mut self) {
        let mut live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(i) = live.iter().rposition(|p| *p == self.0) {
            live.swap_remove(i);
        }
    }
}

fn replace<E>(
    path: &Path,
    existing: Option<&Metadata>,
    opts: &WriteOptions,
    write: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), WriteError<E>> {
    let io = WriteError::Io;
    let dir = folder(path);
    let (tmp, listed) = {
        let mut live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
        let tmp = new_temporary(dir).map_err(io)?;
        live.push(tmp.path().to_path_buf());
        let listed = Listed(tmp.path().to_path_buf());
        (tmp, listed)
    };
    if let Some(m) = existing {
        keep_owner_and_mode(tmp.as_file(), m).map_err(io)?;
    }
    {
        let mut w = BufWriter::with_capacity(1 << 20, tmp.as_file());
        write(&mut w).map_err(WriteError::Write)?;
        w.flush().map_err(io)?;
    }
    tmp.as_file().sync_all().map_err(io)?;
    {
        let _live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
        let persisted = if opts.no_clobber { tmp.persist_noclobber(path) } else { tmp.persist(path) };
        persisted.map_err(
            |e| {
                if e.error.kind() == io::ErrorKind::AlreadyExists { io(exists()) } else { io(e.error) }
            },
        )?;
    }
    drop(listed);
    sync_folder(dir).map_err(io)
}

#[cfg(unix)]
fn new_temporary(dir: &Path) -> io::Result<tempfile::NamedTempFile> {
    use std::os::unix::fs::PermissionsExt;
    // 0o666 less the umask, as any new file.
    tempfile::Builder::new()
        .prefix(".octowrap-")
        .suffix(".tmp")
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(dir)
}

#[cfg(not(unix))]
fn new_temporary(dir: &Path) -> io::Result<tempfile::NamedTempFile> {
    tempfile::Builder::new().prefix(".octowrap-").suffix(".tmp").tempfile_in(dir)
}

/// Gives the temporary the replaced file's owner and group (when the process may: otherwise it
/// stays the process's own) and then its permission bits (set last: a change of owner clears
/// the set-user-ID bit).
#[cfg(unix)]
fn keep_owner_and_mode(file: &File, old: &Metadata) -> io::Result<()> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let now = file.metadata()?;
    if now.uid() != old.uid() || now.gid() != old.gid() {
        // Only the owner may be kept by root; the group by a member of it. Either may fail.
        if std::os::unix::fs::fchown(file, Some(old.uid()), Some(old.gid())).is_err() {
            let _ = std::os::unix::fs::fchown(file, None, Some(old.gid()));
        }
    }
    file.set_permissions(std::fs::Permissions::from_mode(old.mode() & 0o7777))
}

#[cfg(not(unix))]
fn keep_owner_and_mode(file: &File, old: &Metadata) -> io::Result<()> {
    file.set_permissions(old.permissions())
}

/// Syncs the folder, so the rename itself is on disk. File systems that cannot sync a folder
/// (they answer "invalid argument") are left as they are.
fn sync_folder(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    match File::open(dir).and_then(|d| d.sync_all()) {
        Err(e) if e.kind() != io::ErrorKind::InvalidInput && e.kind() != io::ErrorKind::Unsupported => {
            return Err(e);
        }
        _ => {}
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}
