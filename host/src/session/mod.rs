//! The session: what a calibration is made from, as the files give it and
//! the science reads it — the measured rows and their channels, the joint
//! rows, the constraints of a session without a tracker, the configurations
//! its rows repeat, the prior on the geometry, and the checks that the rows
//! can carry a calibration (`require_*`).
//!
//! [`crate::io`] parses files into these types and [`crate::calibration`]
//! reads them; nothing here computes a calibration, and nothing in `io`
//! imports `calibration` (`io_does_not_import_calibration` below checks it).
//!
//! | module | idea |
//! | --- | --- |
//! | [`measurements`] | the measured rows ([`measurements::Observation`]), the session ([`measurements::Measurements`]) and its `require_*` checks |
//! | [`joints`] | rows of joint readings alone ([`joints::JointRows`]) |
//! | [`constraints`] | unknown fixed points and planes, known distances |
//! | [`configurations`] | the distinct configurations the rows repeat, and the pure error of the repeats |
//! | [`channel`] | the kinds of measurement row, each with its own noise |
//! | [`prior`] | the prior scale of the D-H parameter errors |

pub mod channel;
pub mod configurations;
pub mod constraints;
pub mod joints;
pub mod measurements;
pub mod prior;

#[cfg(test)]
mod tests {
    /// The layers' one rule: `io` reads and writes files into the session's
    /// types and knows no calibration, so no source file under `src/io`
    /// names `crate::calibration` outside a comment.
    #[test]
    fn io_does_not_import_calibration() {
        fn sources(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    sources(&path, out);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    out.push(path);
                }
            }
        }
        let mut files = Vec::new();
        sources(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/io"),
            &mut files,
        );
        assert!(files.len() > 5, "{files:?}");
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                assert!(
                    !code.contains("crate::calibration")
                        && !code.contains("super::super::calibration"),
                    "{}:{}: {line}",
                    file.display(),
                    n + 1
                );
            }
        }
    }
}
