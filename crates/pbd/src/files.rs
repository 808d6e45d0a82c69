//! Safe file writing: never over an input, never half-written, never over a special file.
//!
//! Each command declares, before any work, every file it reads (including the files named inside
//! other inputs — a scene's catalog) and every file it writes (including the fixed names inside an
//! output directory) in an [`IoPlan`]; [`IoPlan::check`] refuses any overlap — an output that is an
//! input (same file through `./x`, an absolute path, a symlink, a hard link or `sub/..`; or the same
//! path not yet created), two outputs that are one file, and an output that exists and is not a
//! regular file (a device such as `/dev/null`, a FIFO, a socket: a write through a temporary file
//! and a rename would replace it).

use std::path::Path;

use anyhow::{Context, Result, bail};

/// `true` if `a` and `b` name the same existing file (same device and inode on Unix, same canonical
/// path elsewhere): catches `./x`, absolute paths, symlinks and hard links.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// `p` made absolute and free of `.`/`..` and symlinks as far as it exists: the existing file
/// itself, else its existing directory and its name (a file not yet created).
fn normalized(p: &Path) -> std::path::PathBuf {
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (dir.canonicalize(), p.file_name()) {
        (Ok(d), Some(n)) => d.join(n),
        _ => std::env::current_dir()
            .map(|c| c.join(p))
            .unwrap_or_else(|_| p.to_path_buf()),
    }
}

/// Whether `a` and `b` are one file: the same existing file, or the same path once normalized
/// (a file neither has created yet).
pub fn same_target(a: &Path, b: &Path) -> bool {
    same_file(a, b) || normalized(a) == normalized(b)
}

/// Whether `path` exists and is neither a regular file nor a directory (a device, a FIFO, a
/// socket), following symlinks.
pub fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Refuses to replace `path` when it is a special file ([`is_special`]): writes go through a
/// temporary file and a rename, which would put a regular file in place of a device node.
pub fn refuse_special(path: &Path) -> Result<()> {
    if is_special(path) {
        bail!(
            "cannot write {}: it is not a regular file (a device, FIFO or socket), and pbd writes \
             files whole through a rename, which would replace it; write to a regular file",
            path.display()
        );
    }
    Ok(())
}

/// The files a command reads and writes, declared before it starts ([`IoPlan::check`]).
#[derive(Debug, Default, Clone)]
pub struct IoPlan {
    reads: Vec<(String, std::path::PathBuf)>,
    writes: Vec<(String, std::path::PathBuf)>,
}

impl IoPlan {
    /// An empty plan.
    pub fn new() -> Self {
        IoPlan::default()
    }

    /// Declares an input file (`what` names it in messages: `--scene`, `the scene's catalog`).
    /// Built-in names (`builtin:…`) are not files and are skipped.
    pub fn read(&mut self, what: &str, path: impl AsRef<Path>) -> &mut Self {
        let path = path.as_ref();
        if !path.to_string_lossy().starts_with("builtin:") {
            self.reads.push((what.to_string(), path.to_path_buf()));
        }
        self
    }

    /// Declares an output file.
    pub fn write(&mut self, what: &str, path: impl AsRef<Path>) -> &mut Self {
        self.writes.push((what.to_string(), path.as_ref().to_path_buf()));
        self
    }

    /// Declares the fixed file names a command writes inside output directory `dir`.
    pub fn write_in(&mut self, what: &str, dir: impl AsRef<Path>, names: &[&str]) -> &mut Self {
        for n in names {
            self.writes.push((format!("{what} ({n})"), dir.as_ref().join(n)));
        }
        self
    }

    /// Refuses, before any work, an output that is an input, two outputs that are one file, and an
    /// output that is a special file.
    pub fn check(&self) -> Result<()> {
        for (i, (what, o)) in self.writes.iter().enumerate() {
            refuse_special(o).with_context(|| what.clone())?;
            for (in_what, input) in &self.reads {
                if same_target(input, o) {
                    bail!(
                        "{what} {} is the input {} ({in_what}): refusing to overwrite an input (choose another output)",
                        o.display(),
                        input.display()
                    );
                }
            }
            for (other_what, other) in &self.writes[..i] {
                if same_target(other, o) {
                    bail!(
                        "{what} {} is also {other_what} {}: two outputs cannot be one file (choose another name)",
                        o.display(),
                        other.display()
                    );
                }
            }
        }
        Ok(())
    }
}

/// Refuses to run when an output would overwrite one of the inputs: an [`IoPlan`] of unnamed
/// inputs and outputs, checked.
pub fn refuse_inputs_as_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    let mut plan = IoPlan::new();
    for i in inputs {
        plan.read("input", i);
    }
    for o in outputs {
        plan.write("output", o);
    }
    plan.check()
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so that a
/// reader never sees a half-written file and a failed write leaves any old file untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    refuse_special(path)?;
    let name = path
        .file_name()
        .with_context(|| format!("cannot write {}: not a file name", path.display()))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(".tmp");
    let tmp = path.with_file_name(tmp_name);
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| {
        let _ = std::fs::remove_file(&tmp);
        format!("cannot write {}", path.display())
    })
}

/// A temporary path beside `path` (same directory, so a rename onto `path` is atomic).
pub fn temporary_beside(path: &Path) -> Result<std::path::PathBuf> {
    refuse_special(path)?;
    let name = path
        .file_name()
        .with_context(|| format!("cannot write {}: not a file name", path.display()))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    Ok(path.with_file_name(tmp_name))
}

/// Checks, before long work, that `path` can be written: its directory exists and accepts a new file.
pub fn check_writable(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    if path.is_dir() {
        bail!("cannot write {}: it is a directory", path.display());
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let probe = dir.join(format!(".{name}.{}.probe", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("cannot write {}", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}
