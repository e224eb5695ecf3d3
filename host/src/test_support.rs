//! Helpers shared by the unit tests (file parsers, outputs, calibrations).

/// Applies random edits to `text`: each `(pos, op, pick)` inserts, removes or
/// replaces the character at `pos` (modulo the length) with `alphabet[pick]`, so
/// that property tests explore files that are almost valid.
pub fn mutate(text: &str, edits: &[(usize, u8, usize)], alphabet: &str) -> String {
    let alphabet: Vec<char> = alphabet.chars().collect();
    let mut chars: Vec<char> = text.chars().collect();
    for &(pos, op, pick) in edits {
        let c = alphabet[pick % alphabet.len()];
        let at = if chars.is_empty() {
            0
        } else {
            pos % (chars.len() + 1)
        };
        match op % 3 {
            0 => chars.insert(at, c),
            1 if at < chars.len() => {
                chars.remove(at);
            }
            _ if at < chars.len() => chars[at] = c,
            _ => chars.push(c),
        }
    }
    chars.into_iter().collect()
}

/// A character device `(major, minor)` to write into in a test, without risk
/// to the machine's own: as root (who could replace `/dev/NAME`), a node made
/// in `dir` by `mknod` (`None` if that is not allowed); otherwise `/dev/NAME`
/// itself, which a user cannot replace.
pub fn device(
    dir: &std::path::Path,
    name: &str,
    (major, minor): (u32, u32),
) -> Option<std::path::PathBuf> {
    use std::os::unix::fs::MetadataExt as _;
    let probe = dir.join(".owner-probe");
    std::fs::write(&probe, b"").ok()?;
    let root = std::fs::metadata(&probe).ok()?.uid() == 0;
    std::fs::remove_file(&probe).ok()?;
    if !root {
        return Some(std::path::Path::new("/dev").join(name));
    }
    let node = dir.join(name);
    let made = std::process::Command::new("mknod")
        .arg(&node)
        .args(["c", &major.to_string(), &minor.to_string()])
        .status()
        .is_ok_and(|s| s.success());
    made.then_some(node)
}

/// The RMS distance between `calibrated`'s and `truth`'s tool points at the
/// configurations `held`, m: what a calibration predicts of poses it never
/// saw, without measurement noise.
pub fn true_error(
    calibrated: &armcal_shared::Robot<f64>,
    truth: &armcal_shared::Robot<f64>,
    held: &[Vec<f64>],
) -> f64 {
    let sum: f64 = held
        .iter()
        .map(|q| {
            (calibrated.forward(q).unwrap().translation.vector
                - truth.forward(q).unwrap().translation.vector)
                .norm_squared()
        })
        .sum();
    (sum / held.len() as f64).sqrt()
}
