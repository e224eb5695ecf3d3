//! The session: what a calibration is made from, as the files give it and
//! the science reads it — the measured rows and their channels, the joint
//! rows, the constraints of a session without a tracker, the configurations
//! its rows repeat, the prior on the geometry, and the checks that the rows
//! can carry a calibration (`require_*`), the robot model they are read
//! against, and the refusal every layer gives for an input it cannot take.
//!
//! [`crate::io`] parses files into these types and [`crate::calibration`]
//! reads them; nothing here computes a calibration or reads a file: nothing
//! in `io` imports `calibration`, and nothing here imports `io` or
//! `calibration` (the tests below check both).
//!
//! | module | idea |
//! | --- | --- |
//! | [`observation`] | one measured row ([`observation::Observation`]): joint readings, what its tool point is held to, orientation, context |
//! | [`measurements`] | the session of rows ([`measurements::Measurements`]) and its `require_*` checks |
//! | [`joints`] | rows of joint readings alone ([`joints::JointRows`]) |
//! | [`constraints`] | unknown fixed points and planes, known distances |
//! | [`distinct`] | one session given once among several ([`distinct::require_distinct`]) |
//! | [`configurations`] | the distinct configurations the rows repeat, and the pure error of the repeats |
//! | [`channel`] | the kinds of measurement row, each with its own noise |
//! | [`prior`] | the prior scale of the D-H parameter errors |
//! | [`registration`] | several sessions in one calibration: each session's own base and tool frames |
//! | [`model`] | the robot model: identity, units, the nominal robot in SI, its prior |
//! | [`input_error`] | why an input was refused, and where ([`input_error::InputError`]) |

pub mod channel;
pub mod configurations;
pub mod constraints;
pub mod distinct;
pub mod input_error;
pub mod joints;
pub mod measurements;
pub mod model;
pub mod observation;
pub mod prior;
pub mod registration;

#[cfg(test)]
mod tests {
    /// Asserts that no source file under `src/<dir>` names any of `layers`
    /// (`crate::<layer>` or `super::super::<layer>`) outside a comment.
    fn imports_none_of(dir: &str, layers: &[&str]) {
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
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("src")
                .join(dir),
            &mut files,
        );
        assert!(files.len() > 5, "{files:?}");
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                for layer in layers {
                    assert!(
                        !code.contains(&format!("crate::{layer}"))
                            && !code.contains(&format!("super::super::{layer}")),
                        "{}:{}: {line}",
                        file.display(),
                        n + 1
                    );
                }
            }
        }
    }

    /// The layers' one rule: `io` reads and writes files into the session's
    /// types and knows no calibration, so no source file under `src/io`
    /// names `crate::calibration` outside a comment.
    #[test]
    fn io_does_not_import_calibration() {
        imports_none_of("io", &["calibration"]);
    }

    /// The session sits under both: no source file under `src/session`
    /// names `crate::io` or `crate::calibration` outside a comment.
    #[test]
    fn session_imports_neither_io_nor_calibration() {
        imports_none_of("session", &["io", "calibration"]);
    }
}
