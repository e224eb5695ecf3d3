//! Writing a command's result files: all of them or none, never over an input,
//! never replacing what is not a regular file.
//!
//! A command plans its outputs in one [`Outputs`]: the input files it reads
//! ([`Outputs::input`]) and the path each output flag names
//! ([`Outputs::output`]). [`Outputs::check`] refuses a bad plan before anything
//! is computed, and [`Outputs::commit`] checks again and writes. The contract:
//!
//! - **Never over an input.** An output that names an input file, or the file
//!   another output names, is refused (status 2, naming both flags) and nothing
//!   is written. Files are compared by canonical path and by identity (device
//!   and inode, so a symbolic or hard link to an input counts as the input).
//! - **All or none.** Every output to a file is first written completely to a
//!   temporary `.NAME.PID.armcal-partial` beside its target and flushed to disk;
//!   only when all of them are complete are they renamed over their targets.
//!   Any failure before that (a missing or read-only directory, a full disk)
//!   removes every temporary and leaves every target as it was; so does an
//!   interrupt (Ctrl-C, `SIGTERM`: the binary's handler calls
//!   [`remove_pending`] and exits with status 130). A run killed before its
//!   clean-up (`SIGKILL`, the out-of-memory killer) leaves its temporary; the
//!   next run that plans the same output removes those of processes no longer
//!   running ([`Outputs::check`]). A rename is
//!   atomic; should one fail after another succeeded (practically impossible
//!   once the temporaries exist beside their targets), the error says which
//!   outputs were already replaced.
//! - **Where a path leads.** A symbolic link is followed: the file it leads to
//!   is replaced (created, if the link dangles) and the link stays a link. A
//!   character device (`/dev/null`, a terminal, `/dev/stdout`) or a FIFO is
//!   written into as it is, never replaced: it is opened before any temporary
//!   is created (a FIFO waits there for its reader) and written after all
//!   temporaries are complete, before the renames; bytes sent into a stream
//!   cannot be taken back, so a later failure cannot undo them. An output
//!   written as it is produced ([`Outputs::set_writer`]) goes into its device
//!   in its planned turn instead, as produced. A directory, a
//!   block device (a disk) and a socket are refused with the reason. Devices
//!   and FIFOs are not compared with the inputs: writing into them replaces
//!   nothing.
//! - **Refused before the computation.** [`Outputs::check`] creates and
//!   removes an empty temporary beside each file target: a directory armcal
//!   may not create files in is refused then, not after minutes of work.
//! - Exit status: a refused plan, a missing directory or a directory armcal may
//!   not write in is the user's path (status 2, [`InputError`]); anything else
//!   (a full disk, an I/O error) is status 1.
//!
//! An output too long to hold in memory (`simulate`'s rows) is given as a
//! [`Writer`] instead of bytes: it writes into the temporary (or the device)
//! as it produces, at commit, the writers in the order the outputs were
//! planned.
//!
//! A replaced file keeps its permission bits (not its owner: the new file is
//! armcal's); a hard link of it elsewhere keeps the old content, as with any
//! write-then-rename.

use std::fs::{self, File, OpenOptions};
use std::io::Write as _;
use std::os::unix::fs::{FileTypeExt as _, MetadataExt as _};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use crate::io::builtin;
use crate::session::input_error::InputError;

/// Symbolic links followed from one output path before giving up (as the kernel's `ELOOP`).
const MAX_SYMLINKS: usize = 40;

/// The planned outputs of one run, with the inputs they must not overwrite.
#[derive(Debug, Default)]
pub struct Outputs {
    /// `(flag, name)` of every input, as the user gave it.
    inputs: Vec<(String, String)>,
    outputs: Vec<Planned>,
}

#[derive(Debug)]
struct Planned {
    flag: String,
    path: PathBuf,
    content: Option<Content>,
}

/// Writes an output into the file (or device) it is given as it produces
/// it; called once, at [`Outputs::commit`]. An error fails the commit, as a
/// failed write does.
pub type Writer = Box<dyn FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>>;

/// What an output holds.
enum Content {
    Bytes(Vec<u8>),
    Written(Writer),
}

impl std::fmt::Debug for Content {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Content::Bytes(b) => write!(f, "{} bytes", b.len()),
            Content::Written(_) => f.write_str("written at commit"),
        }
    }
}

impl Content {
    /// Writes the content into `out`.
    fn write_into(self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        match self {
            Content::Bytes(bytes) => out.write_all(&bytes),
            Content::Written(writer) => {
                let mut buffered = std::io::BufWriter::new(out);
                writer(&mut buffered)?;
                buffered.flush()
            }
        }
    }
}

/// Where one output goes.
#[derive(Debug, PartialEq)]
enum Target {
    /// A regular file, existing or not, at this path (symbolic links resolved):
    /// written by a temporary renamed over it.
    File(PathBuf),
    /// A character device or FIFO, written into as it is.
    Stream,
}

/// Where an output is written at commit: a temporary beside its target,
/// renamed over it, or the device or FIFO opened.
enum Destination {
    Temporary(PathBuf),
    Device(File),
}

/// Which file a path names: its canonical path and, if it exists, its device and inode.
#[derive(Debug)]
struct Identity {
    canonical: Option<PathBuf>,
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn same(&self, other: &Identity) -> bool {
        (self.canonical.is_some() && self.canonical == other.canonical)
            || (self.inode.is_some() && self.inode == other.inode)
    }
}

impl Outputs {
    /// No inputs, no outputs.
    pub fn new() -> Self {
        Self::default()
    }

    /// An input file read under `flag` (`--joints`, `--calibration`). A name
    /// that is not a regular file (a device, `/dev/stdin`, a missing file) is
    /// not compared: writing cannot overwrite it.
    pub fn input(mut self, flag: &str, name: &str) -> Self {
        self.inputs.push((flag.to_owned(), name.to_owned()));
        self
    }

    /// The `--model` input: a file unless `name` is a built-in model (which is
    /// read instead of any file of that name).
    pub fn model_input(self, name: &str) -> Self {
        if builtin::builtin_model(name).is_some() {
            self
        } else {
            self.input("--model", name)
        }
    }

    /// The `--data` input: a file unless `name` is a built-in data set.
    pub fn data_input(self, name: &str) -> Self {
        if builtin::builtin_data(name).is_some() {
            self
        } else {
            self.input("--data", name)
        }
    }

    /// [`Outputs::data_input`] of every session named.
    pub fn data_inputs(self, names: &[String]) -> Self {
        names.iter().fold(self, |out, name| out.data_input(name))
    }

    /// An output `flag` asks for at `path`; `None` (not asked for) is ignored.
    /// Its bytes are given later by [`set`](Self::set).
    pub fn output(mut self, flag: &str, path: Option<&Path>) -> Self {
        if let Some(path) = path {
            self.outputs.push(Planned {
                flag: flag.to_owned(),
                path: path.to_owned(),
                content: None,
            });
        }
        self
    }

    /// True when no output was asked for.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    /// The bytes of the output planned under `flag`.
    ///
    /// # Panics
    /// If no output was planned under `flag` (a bug of the caller).
    pub fn set(&mut self, flag: &str, bytes: Vec<u8>) {
        let planned = self
            .outputs
            .iter_mut()
            .find(|p| p.flag == flag)
            .unwrap_or_else(|| panic!("no output planned under {flag}"));
        planned.content = Some(Content::Bytes(bytes));
    }

    /// Gives the output planned at `path` (one flag may name several files:
    /// `simulate --sessions`) as a [`Writer`], called at commit.
    ///
    /// # Panics
    /// If no output was planned at `path` (a bug of the caller).
    pub fn set_writer(&mut self, path: &Path, writer: Writer) {
        let planned = self
            .outputs
            .iter_mut()
            .find(|p| p.path == path)
            .unwrap_or_else(|| panic!("no output planned at {}", path.display()));
        planned.content = Some(Content::Written(writer));
    }

    /// Checks the plan (see [the module](self)) without writing anything:
    /// returns the refusal of the first output that names an input or another
    /// output, a directory, a block device, a socket, or a place in a missing
    /// directory.
    pub fn check(&self) -> Result<(), InputError> {
        for (planned, target) in self.outputs.iter().zip(self.targets()?) {
            if let Target::File(path) = target {
                remove_stale(&path);
                probe(planned, &path)?;
            }
        }
        Ok(())
    }

    /// Writes every output, all or none (see [the module](self)), after checking
    /// the plan again. An output without content is an error of the program.
    pub fn commit(self) -> anyhow::Result<()> {
        let targets = self.targets()?;
        let mut outputs = Vec::with_capacity(self.outputs.len());
        for (mut planned, target) in self.outputs.into_iter().zip(targets) {
            let content = planned
                .content
                .take()
                .ok_or_else(|| anyhow::anyhow!("internal error: no bytes for {}", planned.flag))?;
            outputs.push((planned, target, content));
        }

        // Streams are opened first: a FIFO waits here for its reader, and no
        // temporary exists yet that an interrupt would leave behind.
        let mut opened = Vec::with_capacity(outputs.len());
        for (planned, target, content) in outputs {
            let destination = match target {
                Target::File(path) => Destination::Temporary(path),
                Target::Stream => Destination::Device(
                    OpenOptions::new()
                        .write(true)
                        .open(&planned.path)
                        .map_err(|e| failure(&planned, "cannot open it for writing", e))?,
                ),
            };
            opened.push((planned, destination, content));
        }

        // In the planned order: the temporaries, and the streams written as
        // produced; the streams of bytes after every temporary is complete.
        let into_stream = |planned: &Planned, file: &mut File, content: Content| {
            content
                .write_into(file)
                .and_then(|()| file.flush())
                .map_err(|e| {
                    failure(
                        planned,
                        "cannot write into it (the outputs to files were not written)",
                        e,
                    )
                })
        };
        let mut temporaries = Temporaries::default();
        let mut renames = Vec::new();
        let mut streams = Vec::new();
        for (planned, destination, content) in opened {
            match (destination, content) {
                (Destination::Temporary(path), content) => {
                    let tmp = temporaries.write(&path, content).map_err(|e| {
                        failure(&planned, "cannot write it (no output was written)", e)
                    })?;
                    renames.push((planned, tmp, path));
                }
                (Destination::Device(mut file), content @ Content::Written(_)) => {
                    into_stream(&planned, &mut file, content)?;
                }
                (Destination::Device(file), bytes) => streams.push((planned, file, bytes)),
            }
        }
        for (planned, mut file, content) in streams {
            into_stream(&planned, &mut file, content)?;
        }

        let mut replaced: Vec<String> = Vec::new();
        for (planned, tmp, path) in renames {
            if let Err(e) = fs::rename(&tmp, &path) {
                let already = if replaced.is_empty() {
                    "no output was written".to_owned()
                } else {
                    format!(
                        "{} already replaced, the other outputs were not written",
                        replaced.join(", ")
                    )
                };
                return Err(failure(
                    &planned,
                    &format!("cannot replace it ({already})"),
                    e,
                ));
            }
            temporaries.renamed += 1;
            replaced.push(format!("{} {}", planned.flag, planned.path.display()));
            // The rename itself reaches the disk with its directory.
            if let Ok(dir) = File::open(parent_of(&path)) {
                let _ = dir.sync_all();
            }
        }
        Ok(())
    }

    /// The target of every output, in order, or the first refusal.
    fn targets(&self) -> Result<Vec<Target>, InputError> {
        let inputs: Vec<(&str, &str, Identity)> = self
            .inputs
            .iter()
            .filter_map(|(flag, name)| {
                let meta = fs::metadata(name).ok().filter(|m| m.is_file())?;
                let identity = Identity {
                    canonical: fs::canonicalize(name).ok(),
                    inode: Some((meta.dev(), meta.ino())),
                };
                Some((flag.as_str(), name.as_str(), identity))
            })
            .collect();
        let mut targets = Vec::with_capacity(self.outputs.len());
        let mut files: Vec<(&Planned, Identity)> = Vec::new();
        for planned in &self.outputs {
            let target = classify(planned)?;
            if let Target::File(path) = &target {
                let identity = identity(path);
                let refuse = |message: String| {
                    InputError::argument(
                        format!("{} {}", planned.flag, planned.path.display()),
                        message,
                    )
                };
                if let Some((flag, name, _)) = inputs.iter().find(|(_, _, i)| i.same(&identity)) {
                    return Err(refuse(format!(
                        "names the input {flag} {name}: refusing to overwrite it"
                    )));
                }
                if let Some((other, _)) = files.iter().find(|(_, i)| i.same(&identity)) {
                    return Err(refuse(format!(
                        "names the same file as {} {}: give each output its own file",
                        other.flag,
                        other.path.display()
                    )));
                }
                files.push((planned, identity));
            }
            targets.push(target);
        }
        Ok(targets)
    }
}

/// Where `planned` leads, or why it is refused.
fn classify(planned: &Planned) -> Result<Target, InputError> {
    let path = &planned.path;
    let refuse = |message: String| {
        InputError::argument(format!("{} {}", planned.flag, path.display()), message)
    };
    if path.as_os_str().is_empty() {
        return Err(refuse("an empty path".to_owned()));
    }
    match fs::metadata(path) {
        Ok(meta) => {
            let kind = meta.file_type();
            if kind.is_file() {
                Ok(Target::File(resolve_links(path).map_err(refuse)?))
            } else if kind.is_char_device() || kind.is_fifo() {
                Ok(Target::Stream)
            } else if kind.is_dir() {
                Err(refuse("is a directory: name a file".to_owned()))
            } else if kind.is_block_device() {
                Err(refuse(
                    "is a block device (a disk): armcal does not write results into one".to_owned(),
                ))
            } else if kind.is_socket() {
                Err(refuse(
                    "is a socket: armcal writes into files, character devices and FIFOs".to_owned(),
                ))
            } else {
                Err(refuse("is not a file armcal can write".to_owned()))
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A new file, or a dangling link: created where the links lead.
            let resolved = resolve_links(path).map_err(refuse)?;
            if resolved.file_name().is_none() {
                return Err(refuse("does not name a file".to_owned()));
            }
            let dir = parent_of(&resolved);
            match fs::metadata(dir) {
                Ok(meta) if meta.is_dir() => Ok(Target::File(resolved)),
                Ok(_) => Err(refuse(format!("{} is not a directory", dir.display()))),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(refuse(format!(
                    "the directory {} does not exist",
                    dir.display()
                ))),
                Err(e) => Err(refuse(format!("cannot reach {}: {e}", dir.display()))),
            }
        }
        Err(e) => Err(refuse(format!("cannot write there: {e}"))),
    }
}

/// The temporary of `target` for process `pid` (`-attempt` after a name
/// taken): `.NAME.PID[-k].armcal-partial` beside it.
fn temporary_name(target: &Path, pid: u32, attempt: usize) -> Option<PathBuf> {
    let prefix = temporary_prefix(target)?;
    let suffix = if attempt == 0 {
        String::new()
    } else {
        format!("-{attempt}")
    };
    Some(target.with_file_name(format!("{prefix}{pid}{suffix}{PARTIAL}")))
}

/// What every temporary of `target` starts with, `.NAME.`: its name cut
/// short enough for the file system whatever the target's (255 bytes).
fn temporary_prefix(target: &Path) -> Option<String> {
    let name: String = target
        .file_name()?
        .to_string_lossy()
        .chars()
        .take(120)
        .collect();
    Some(format!(".{name}."))
}

/// What every temporary's name ends with.
const PARTIAL: &str = ".armcal-partial";

/// Whether process `pid` may be running: `false` only when the system's
/// process table (`/proc`) says it is not.
fn may_be_running(pid: u32) -> bool {
    !Path::new("/proc/self").exists() || Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the temporaries of `target` that a run killed before it could
/// clean up left behind (`SIGKILL`, the out-of-memory killer): those of a
/// process no longer running. A running one's are its own.
fn remove_stale(target: &Path) {
    let (Some(prefix), Ok(entries)) = (temporary_prefix(target), fs::read_dir(parent_of(target)))
    else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(PARTIAL))
        else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid
            && pid != std::process::id()
            && !may_be_running(pid)
        {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Refuses `planned` before anything is computed when its directory does not
/// let armcal create the temporary it will write (permissions, a read-only or
/// pseudo file system): an empty temporary is created and removed at once.
fn probe(planned: &Planned, target: &Path) -> Result<(), InputError> {
    let Some(tmp) = temporary_name(target, std::process::id(), 0) else {
        return Ok(());
    };
    locked(&PENDING).push(tmp.clone());
    let created = OpenOptions::new().write(true).create_new(true).open(&tmp);
    let result = match created {
        Ok(_) => {
            let _ = fs::remove_file(&tmp);
            Ok(())
        }
        // Another temporary of this run, or of a run with our number.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(InputError::argument(
            format!("{} {}", planned.flag, planned.path.display()),
            format!("cannot write there: {e} (nothing was computed, nothing written)"),
        )),
    };
    settled(&tmp);
    result
}

/// `path` with the symbolic links of its last component followed to the name
/// they lead to (which need not exist).
fn resolve_links(path: &Path) -> Result<PathBuf, String> {
    let mut path = path.to_owned();
    for _ in 0..MAX_SYMLINKS {
        match fs::symlink_metadata(&path) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let target = fs::read_link(&path)
                    .map_err(|e| format!("cannot read the link {}: {e}", path.display()))?;
                path = parent_of(&path).join(target);
            }
            _ => return Ok(path),
        }
    }
    Err(format!("more than {MAX_SYMLINKS} symbolic links"))
}

/// The directory of `path` (`.` for a bare file name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// The identity of the regular file (or the name of a new one) at `path`,
/// whose links are resolved.
fn identity(path: &Path) -> Identity {
    let canonical = path.file_name().and_then(|name| {
        fs::canonicalize(parent_of(path))
            .ok()
            .map(|dir| dir.join(name))
    });
    let inode = fs::metadata(path).ok().map(|m| (m.dev(), m.ino()));
    Identity { canonical, inode }
}

/// A refused or failed output: the user's path (status 2) when the directory
/// may not be written in, else a failure of the machine (status 1).
fn failure(planned: &Planned, what: &str, e: std::io::Error) -> anyhow::Error {
    use std::io::ErrorKind::{NotADirectory, NotFound, PermissionDenied, ReadOnlyFilesystem};
    let name = format!("{} {}", planned.flag, planned.path.display());
    if matches!(
        e.kind(),
        PermissionDenied | ReadOnlyFilesystem | NotFound | NotADirectory
    ) {
        InputError::argument(name, format!("{what}: {e}")).into()
    } else {
        anyhow::anyhow!("{name}: {what}: {e}")
    }
}

/// The temporaries of every commit in progress, not renamed yet: what
/// [`remove_pending`] removes when the process is interrupted.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporaries of every commit in progress: the handler of an
/// interrupt (Ctrl-C, `SIGTERM`) calls it before the process ends, so that an
/// interrupted run leaves no `.armcal-partial` file behind.
pub fn remove_pending() {
    remove_all(&PENDING);
}

/// The list `pending`, locked (a thread that panicked holding it left a
/// usable list).
fn locked(pending: &Mutex<Vec<PathBuf>>) -> MutexGuard<'_, Vec<PathBuf>> {
    pending.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes and forgets every file of `pending`.
fn remove_all(pending: &Mutex<Vec<PathBuf>>) {
    for tmp in locked(pending).drain(..) {
        let _ = fs::remove_file(tmp);
    }
}

/// `tmp` is no longer a temporary in progress (renamed or removed).
fn settled(tmp: &Path) {
    locked(&PENDING).retain(|p| p != tmp);
}

/// The temporaries of a commit; those not renamed yet are removed when it is
/// dropped, on every path out of [`Outputs::commit`].
#[derive(Default)]
struct Temporaries {
    paths: Vec<PathBuf>,
    /// How many of `paths`, from the first, were renamed over their targets.
    renamed: usize,
}

impl Temporaries {
    /// Writes `content` to a new temporary beside `target`, flushed to disk,
    /// with the permissions of `target` if it exists; returns its path.
    fn write(&mut self, target: &Path, content: Content) -> std::io::Result<PathBuf> {
        let pid = std::process::id();
        let mut attempt = 0;
        let (tmp, mut file) = loop {
            let tmp = temporary_name(target, pid, attempt)
                .ok_or_else(|| std::io::Error::other("not a file name"))?;
            match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                Ok(file) => {
                    locked(&PENDING).push(tmp.clone());
                    break (tmp, file);
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                    attempt += 1;
                }
                Err(e) => return Err(e),
            }
        };
        self.paths.push(tmp.clone());
        if let Ok(meta) = fs::metadata(target) {
            file.set_permissions(meta.permissions())?;
        }
        content.write_into(&mut file)?;
        file.sync_all()?;
        Ok(tmp)
    }
}

impl Drop for Temporaries {
    fn drop(&mut self) {
        for (i, tmp) in self.paths.iter().enumerate() {
            if i >= self.renamed {
                let _ = fs::remove_file(tmp);
            }
            settled(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The regular files in `dir` with their bytes, sorted by name.
    fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut files: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap())
            .filter(|e| e.file_type().unwrap().is_file())
            .map(|e| {
                let bytes = fs::read(e.path()).unwrap();
                (e.file_name().to_string_lossy().into_owned(), bytes)
            })
            .collect();
        files.sort();
        files
    }

    /// Two outputs, one into a missing directory: refused before anything is
    /// written, and the refusal names the flag, the path and the directory.
    #[test]
    fn a_missing_directory_is_refused_before_any_write() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.cal");
        let r = dir.path().join("missing/r.json");
        let mut outputs = Outputs::new()
            .output("--out", Some(&a))
            .output("--json", Some(&r));
        let e = outputs.check().unwrap_err();
        assert!(e.to_string().starts_with("--json "), "{e}");
        assert!(e.to_string().contains("does not exist"), "{e}");
        outputs.set("--out", b"cal".to_vec());
        outputs.set("--json", b"{}".to_vec());
        let e = outputs.commit().unwrap_err();
        assert!(e.downcast_ref::<InputError>().is_some(), "{e}");
        assert!(snapshot(dir.path()).is_empty());
    }

    /// A failure after the temporaries are written (here: a stream that is
    /// full, as a full disk would be) removes every temporary and leaves every
    /// target as it was; so does a directory removed between check and commit.
    /// An interrupt between the writing of a commit's temporaries and their
    /// renaming: each temporary is pending until renamed or removed, and the
    /// interrupt's clean-up removes every pending one (here on a list of this
    /// test's own, as other tests commit beside it).
    #[test]
    fn an_interrupted_commit_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let pending = |tmp: &Path| PENDING.lock().unwrap().iter().any(|p| p == tmp);
        let mut temporaries = Temporaries::default();
        let a = temporaries
            .write(&dir.path().join("a.cal"), Content::Bytes(b"new".to_vec()))
            .unwrap();
        let b = temporaries
            .write(&dir.path().join("r.json"), Content::Bytes(b"{}".to_vec()))
            .unwrap();
        assert!(pending(&a) && pending(&b));
        fs::rename(&a, dir.path().join("a.cal")).unwrap();
        temporaries.renamed = 1;
        drop(temporaries);
        assert!(!pending(&a) && !pending(&b), "settled when the commit ends");
        assert_eq!(
            snapshot(dir.path()),
            vec![("a.cal".to_owned(), b"new".to_vec())]
        );

        // The interrupt's clean-up of what is still pending.
        let mine = Mutex::new(Vec::new());
        for name in ["a.cal", "r.json"] {
            let tmp = dir.path().join(format!(".{name}.1.armcal-partial"));
            fs::write(&tmp, b"partial").unwrap();
            mine.lock().unwrap().push(tmp);
        }
        remove_all(&mine);
        assert!(mine.lock().unwrap().is_empty());
        assert_eq!(
            snapshot(dir.path()),
            vec![("a.cal".to_owned(), b"new".to_vec())]
        );
    }

    /// A run killed before its clean-up (`SIGKILL`) leaves its temporary: the
    /// next run planning the same output removes it when its process is gone
    /// (a process number above any the kernel gives), and leaves a running
    /// process's (1, the init process) alone. The check creates nothing.
    #[test]
    fn a_killed_run_s_temporary_is_removed_by_the_next() {
        if !Path::new("/proc/self").exists() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let dead = dir.path().join(".a.cal.4294967294.armcal-partial");
        let running = dir.path().join(".a.cal.1-2.armcal-partial");
        let other = dir.path().join(".b.cal.4294967294.armcal-partial");
        for tmp in [&dead, &running, &other] {
            fs::write(tmp, b"partial").unwrap();
        }
        let outputs = Outputs::new().output("--out", Some(&dir.path().join("a.cal")));
        outputs.check().unwrap();
        let names: Vec<String> = snapshot(dir.path()).into_iter().map(|(n, _)| n).collect();
        assert_eq!(
            names,
            [
                ".a.cal.1-2.armcal-partial",
                ".b.cal.4294967294.armcal-partial"
            ]
        );
    }

    /// A directory armcal may not create files in is refused by the check,
    /// before anything is computed, even for root: `/proc` takes no new file.
    #[test]
    fn an_unwritable_directory_is_refused_before_the_computation() {
        if !Path::new("/proc/self").exists() {
            return;
        }
        let outputs = Outputs::new().output("--out", Some(Path::new("/proc/armcal-probe.cal")));
        let e = outputs.check().unwrap_err().to_string();
        assert!(
            e.contains("--out /proc/armcal-probe.cal") && e.contains("cannot write there"),
            "{e}"
        );
        assert!(!Path::new("/proc/armcal-probe.cal").exists());
    }

    #[test]
    fn a_failed_commit_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("a.cal"), b"old").unwrap();
        if let Some(full) = crate::test_support::device(dir.path(), "full", (1, 7)) {
            let mut outputs = Outputs::new()
                .output("--out", Some(&dir.path().join("a.cal")))
                .output("--json", Some(&full));
            outputs.set("--out", b"new".to_vec());
            outputs.set("--json", b"{}".to_vec());
            let e = outputs.commit().unwrap_err();
            assert!(e.to_string().contains("were not written"), "{e}");
            assert!(
                fs::metadata(&full).unwrap().file_type().is_char_device(),
                "the device stays"
            );
            let _ = fs::remove_file(dir.path().join("full"));
        }
        assert_eq!(
            snapshot(dir.path()),
            vec![("a.cal".to_owned(), b"old".to_vec())]
        );

        let sub = dir.path().join("sub");
        fs::create_dir(&sub).unwrap();
        let mut outputs = Outputs::new()
            .output("--out", Some(&dir.path().join("a.cal")))
            .output("--json", Some(&sub.join("r.json")));
        outputs.check().unwrap();
        outputs.set("--out", b"new".to_vec());
        outputs.set("--json", b"{}".to_vec());
        fs::remove_dir(&sub).unwrap();
        let e = outputs.commit().unwrap_err();
        assert!(e.to_string().contains("does not exist"), "{e}");
        assert_eq!(
            snapshot(dir.path()),
            vec![("a.cal".to_owned(), b"old".to_vec())]
        );
    }

    /// A name as long as the file system allows still gets its temporary.
    /// An output given as a writer is written as it produces, in the
    /// planned order (the sessions of `simulate` share one generator); one
    /// that fails, here after writing half its rows, fails the commit as a
    /// failed write does: no target replaced, no temporary left.
    #[test]
    fn writers_write_in_order_and_a_failed_one_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
        fs::write(&a, b"old").unwrap();
        let order = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
        let writer = |name: &'static str, fail: bool| -> Writer {
            let order = std::rc::Rc::clone(&order);
            Box::new(move |out| {
                order.borrow_mut().push(name);
                out.write_all(format!("{name} row 1\n").as_bytes())?;
                if fail {
                    return Err(std::io::Error::other("the draw failed"));
                }
                out.write_all(format!("{name} row 2\n").as_bytes())
            })
        };
        let plan = || {
            Outputs::new()
                .output("--out", Some(&a))
                .output("--out", Some(&b))
        };
        let mut outputs = plan();
        outputs.set_writer(&a, writer("a", false));
        outputs.set_writer(&b, writer("b", true));
        let e = outputs.commit().unwrap_err();
        assert!(e.to_string().contains("the draw failed"), "{e}");
        assert_eq!(
            snapshot(dir.path()),
            vec![("a.csv".to_owned(), b"old".to_vec())]
        );

        let mut outputs = plan();
        outputs.set_writer(&b, writer("b", false));
        outputs.set_writer(&a, writer("a", false));
        outputs.commit().unwrap();
        assert_eq!(
            snapshot(dir.path()),
            vec![
                ("a.csv".to_owned(), b"a row 1\na row 2\n".to_vec()),
                ("b.csv".to_owned(), b"b row 1\nb row 2\n".to_vec()),
            ]
        );
        assert_eq!(*order.borrow(), ["a", "b", "a", "b"], "planned order");
    }

    #[test]
    fn a_long_name_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let long = dir.path().join("x".repeat(255));
        let mut outputs = Outputs::new().output("--out", Some(&long));
        outputs.set("--out", b"new".to_vec());
        outputs.commit().unwrap();
        assert_eq!(fs::read(&long).unwrap(), b"new");
    }

    /// An output is refused when it names an input (directly, through a symbolic
    /// link or a hard link) or another output (by another spelling); a built-in
    /// model name is not a file.
    #[test]
    fn outputs_never_name_an_input_or_each_other() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("d.csv");
        fs::write(&d, b"q1,x,y,z\n").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("d.csv", &link).unwrap();
        let hard = dir.path().join("hard.csv");
        fs::hard_link(&d, &hard).unwrap();
        let d_str = d.to_str().unwrap();
        for out in [&d, &link, &hard, &dir.path().join("./sub/../d.csv")] {
            fs::create_dir_all(dir.path().join("sub")).unwrap();
            let e = Outputs::new()
                .data_input(d_str)
                .output("--out", Some(out))
                .check()
                .unwrap_err();
            assert!(
                e.to_string().ends_with(&format!(
                    "names the input --data {d_str}: refusing to overwrite it"
                )),
                "{e}"
            );
        }
        let e = Outputs::new()
            .output("--out", Some(&dir.path().join("new.cal")))
            .output("--json", Some(&dir.path().join("sub/../new.cal")))
            .check()
            .unwrap_err();
        assert!(
            e.to_string().contains("names the same file as --out"),
            "{e}"
        );

        // `puma560` is the built-in model, whatever file has that name.
        fs::write(dir.path().join("puma560"), b"x").unwrap();
        let cwd_file = dir.path().join("puma560");
        Outputs::new()
            .model_input("puma560")
            .output("--out", Some(&cwd_file))
            .check()
            .unwrap();
    }

    /// A symbolic link is followed: the file it leads to is replaced, the link
    /// stays; a dangling link creates its target.
    #[test]
    fn links_are_followed_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("real.json"), b"old").unwrap();
        let link = dir.path().join("r.json");
        std::os::unix::fs::symlink("real.json", &link).unwrap();
        let dangling = dir.path().join("d.json");
        std::os::unix::fs::symlink("made.json", &dangling).unwrap();
        let mut outputs = Outputs::new()
            .output("--json", Some(&link))
            .output("--html", Some(&dangling));
        outputs.set("--json", b"new".to_vec());
        outputs.set("--html", b"page".to_vec());
        outputs.commit().unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert!(
            fs::symlink_metadata(&dangling)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(dir.path().join("real.json")).unwrap(), b"new");
        assert_eq!(fs::read(dir.path().join("made.json")).unwrap(), b"page");
        assert_eq!(snapshot(dir.path()).len(), 2, "no temporary left");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 4);
    }

    /// A replaced file keeps its permission bits.
    #[test]
    fn a_replaced_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.cal");
        fs::write(&a, b"old").unwrap();
        fs::set_permissions(&a, fs::Permissions::from_mode(0o640)).unwrap();
        let mut outputs = Outputs::new().output("--out", Some(&a));
        outputs.set("--out", b"new".to_vec());
        outputs.commit().unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"new");
        assert_eq!(
            fs::metadata(&a).unwrap().permissions().mode() & 0o777,
            0o640
        );
    }

    /// A directory is refused, not replaced.
    #[test]
    fn a_directory_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = Outputs::new()
            .output("--json", Some(dir.path()))
            .check()
            .unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
    }
}
