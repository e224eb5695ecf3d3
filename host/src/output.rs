//! Writing result files so that a reader never sees half of one.
//!
//! Every output is written to a temporary file beside its destination and renamed
//! over it only when complete; all outputs of a command are prepared in memory
//! first, so a command that fails writes nothing.

use std::path::Path;

use anyhow::Context as _;

/// Writes `bytes` to `path` atomically (write a sibling temporary file, then rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .with_context(|| format!("{}: not a file name", path.display()))?;
    let tmp = path.with_file_name(format!(".{}.armcal-partial", name.to_string_lossy()));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| {
        let _ = std::fs::remove_file(&tmp);
        format!("cannot write {}", path.display())
    })
}

/// Writes each `(path, bytes)`; every one is complete before the next starts.
pub fn write_all(outputs: &[(&Path, Vec<u8>)]) -> anyhow::Result<()> {
    for (path, bytes) in outputs {
        write_atomically(path, bytes)?;
    }
    Ok(())
}
