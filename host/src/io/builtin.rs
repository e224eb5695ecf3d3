//! Robot models and measurement sets built into the binary.
//!
//! The files are those of the repository's `models/` (robot models, `docs/file-formats.md`
//! §1) and `data/<name>/measurements.csv` (measurements, `docs/file-formats.md` §2),
//! included with `include_str!`, so that `armcal identify --model puma560` works
//! from any directory. `models/README.md` and each `data/<name>/README.md` give
//! their sources and licences. Units are those each file declares; nothing is
//! converted here.
//!
//! Names: a built-in model is named for its file (`puma560`, `ur5e`, `ur10e`), and
//! a real data set and the model that goes with it share the data set's folder
//! name (`figaroh-ur10e-camera`, ...). [`crate::io::model_file::load_model`] and
//! [`crate::io::measurements::load_measurements`] look a name up here before trying it
//! as a path.

use crate::session::input_error::InputError;

/// One built-in file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuiltinFile {
    /// The name it is called by (`--model puma560`).
    pub name: &'static str,
    /// Its path in the repository, used as the file name in error messages.
    pub file: &'static str,
    /// Its text.
    pub text: &'static str,
}

macro_rules! builtin_file {
    ($name:literal, $file:literal) => {
        BuiltinFile {
            name: $name,
            file: $file,
            text: include_str!(concat!("../../../", $file)),
        }
    };
}

/// The built-in robot models.
pub const MODELS: &[BuiltinFile] = &[
    builtin_file!("puma560", "models/puma560.toml"),
    builtin_file!("ur5e", "models/ur5e.toml"),
    builtin_file!("ur10", "models/ur10.toml"),
    builtin_file!("ur10e", "models/ur10e.toml"),
    builtin_file!("figaroh-ur10e-camera", "models/figaroh-ur10e-camera.toml"),
    builtin_file!("figaroh-tiago-mocap", "models/figaroh-tiago-mocap.toml"),
    builtin_file!(
        "figaroh-talos-left-arm",
        "models/figaroh-talos-left-arm.toml"
    ),
];

/// The built-in measurement sets (real data, Apache-2.0); each has a built-in
/// model of the same name.
pub const DATA: &[BuiltinFile] = &[
    builtin_file!(
        "figaroh-ur10e-camera",
        "data/figaroh-ur10e-camera/measurements.csv"
    ),
    builtin_file!(
        "figaroh-tiago-mocap",
        "data/figaroh-tiago-mocap/measurements.csv"
    ),
    builtin_file!(
        "figaroh-talos-left-arm",
        "data/figaroh-talos-left-arm/measurements.csv"
    ),
];

/// The names of [`MODELS`], for `--help` and error messages.
pub const MODEL_NAMES: [&str; MODELS.len()] = names(MODELS);

/// The names of [`DATA`], for `--help` and error messages.
pub const DATA_NAMES: [&str; DATA.len()] = names(DATA);

const fn names<const N: usize>(files: &'static [BuiltinFile]) -> [&'static str; N] {
    let mut out = [""; N];
    let mut i = 0;
    while i < N && i < files.len() {
        out[i] = files[i].name;
        i += 1;
    }
    out
}

/// The text and file label (`models/<name>.toml`) of the built-in model `name`.
pub fn builtin_model(name: &str) -> Option<(&'static str, &'static str)> {
    MODELS
        .iter()
        .find(|m| m.name == name)
        .map(|m| (m.text, m.file))
}

/// The text and file label (`data/<name>/measurements.csv`) of the built-in
/// measurement set `name`.
pub fn builtin_data(name: &str) -> Option<(&'static str, &'static str)> {
    DATA.iter()
        .find(|d| d.name == name)
        .map(|d| (d.text, d.file))
}

/// A file that could not be read (`e`, at line 0) named by what the user
/// gave as a file or a built-in name: the message says it is not a built-in
/// `what` either (`model`, `data set`) and lists `names`. A refusal inside a
/// file that was read is left as it is.
pub fn nor_builtin(
    what: &'static str,
    names: &'static [&'static str],
) -> impl FnOnce(InputError) -> InputError {
    move |mut e| {
        if e.line == 0 {
            e.message = format!(
                "{} (and it is not a built-in {what}: {})",
                e.message,
                names.join(", ")
            );
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names are unique, every data set has its model, and the look-ups find them.
    #[test]
    fn names_are_unique_and_data_sets_have_models() {
        assert_eq!(MODEL_NAMES.len(), MODELS.len());
        assert_eq!(DATA_NAMES.len(), DATA.len());
        assert!(MODELS.iter().zip(MODEL_NAMES).all(|(m, n)| m.name == n));
        assert!(DATA.iter().zip(DATA_NAMES).all(|(d, n)| d.name == n));
        let mut names = MODEL_NAMES.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), MODELS.len());
        for d in DATA {
            assert!(builtin_model(d.name).is_some(), "{} has no model", d.name);
            assert_eq!(builtin_data(d.name).map(|(_, f)| f), Some(d.file));
        }
        assert!(builtin_model("rokae-lasertracker").is_none());
        assert!(builtin_data("no-such-set").is_none());
    }
}
