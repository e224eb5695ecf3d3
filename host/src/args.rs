//! Value parsers of the command line: what an argument must be, checked by
//! clap before any file is read or written.
//!
//! A refused value exits with status 2 and clap's message `invalid value 'V'
//! for '--FLAG <NAME>': what it must be`. Numbers are in the model's units
//! (its length and angle units, docs/file-formats.md §1) except where a flag says SI; the
//! verbs convert them. Bounds that depend on the model or the data (a joint
//! number, the folds against the number of poses) are checked by the verb once
//! those are read.

use nalgebra::Vector3;

/// A strictly positive finite number: a noise or a prior scale stated by the
/// user (a length or an angle in the model's units).
pub(crate) fn positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("must be a positive number".into()),
    }
}

/// A finite number: a temperature, °C.
pub(crate) fn finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err("must be a finite number".into()),
    }
}

/// A finite number, zero or more: a simulated noise (zero simulates exact data).
pub(crate) fn non_negative(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err("must be a non-negative number".into()),
    }
}

/// A count of at least `min` (poses of a simulated session, folds).
pub(crate) fn at_least(
    min: usize,
    what: &'static str,
) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |text| match text.trim().parse::<usize>() {
        Ok(n) if n >= min => Ok(n),
        _ => Err(format!("at least {min} {what}")),
    }
}

/// `--tip-point x,y,z`: the measured point in the tip link's frame, m.
pub(crate) fn tip_point(text: &str) -> Result<Vector3<f64>, String> {
    let parts: Vec<Option<f64>> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    match parts.as_slice() {
        [Some(x), Some(y), Some(z)] => Ok(Vector3::new(*x, *y, *z)),
        _ => Err("expected x,y,z, three finite numbers in m".into()),
    }
}

/// `--tool X,Y,Z[,RX,RY,RZ]`: the working tool in the flange frame, three or
/// six finite numbers (model units; roll, pitch, yaw 0 when not given).
pub(crate) fn tool_frame(text: &str) -> Result<[f64; 6], String> {
    let parts: Vec<Option<f64>> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    match parts.as_slice() {
        [Some(x), Some(y), Some(z)] => Ok([*x, *y, *z, 0.0, 0.0, 0.0]),
        [Some(x), Some(y), Some(z), Some(r), Some(p), Some(w)] => Ok([*x, *y, *z, *r, *p, *w]),
        _ => Err(
            "expected x,y,z or x,y,z,roll,pitch,yaw: three or six finite numbers in the model's units"
                .into(),
        ),
    }
}

/// `--tilt JOINT:BETA`: a hidden Hayati tilt β (rad) at joint `JOINT` (from 1).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tilt {
    /// The joint, from 1 (checked against the model by `simulate`).
    pub joint: usize,
    /// The tilt, rad.
    pub beta: f64,
}

/// Parses `JOINT:BETA`.
pub(crate) fn tilt(text: &str) -> Result<Tilt, String> {
    let parsed = text.split_once(':').and_then(|(j, b)| {
        Some(Tilt {
            joint: j.trim().parse().ok()?,
            beta: b.trim().parse().ok()?,
        })
    });
    match parsed {
        Some(t) if t.joint >= 1 && t.beta.is_finite() => Ok(t),
        _ => Err("expected JOINT:BETA, a joint from 1 and a finite β in rad".into()),
    }
}

/// `LENGTH,ANGLE`, two finite numbers, zero or more: the size of the true
/// robot's errors (`--link-errors`, `--base-errors`, `--tool-errors`).
pub(crate) fn error_sizes(text: &str) -> Result<[f64; 2], String> {
    let parsed = text.split_once(',').and_then(|(l, a)| {
        let (l, a) = (non_negative(l).ok()?, non_negative(a).ok()?);
        Some([l, a])
    });
    parsed.ok_or_else(|| "expected LENGTH,ANGLE, two non-negative numbers".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What each parser takes and refuses: the boundaries of its range, and the
    /// non-finite numbers `f64::from_str` would accept.
    #[test]
    fn each_parser_takes_its_range_and_refuses_the_rest() {
        assert_eq!(positive("2e-5"), Ok(2e-5));
        for bad in ["0", "-1", "nan", "inf", "", "1mm"] {
            assert!(positive(bad).is_err(), "{bad}");
        }
        assert_eq!(non_negative("0"), Ok(0.0));
        for bad in ["-0.1", "nan", "-inf"] {
            assert!(non_negative(bad).is_err(), "{bad}");
        }
        let folds = at_least(2, "folds");
        assert_eq!(folds("2"), Ok(2));
        assert_eq!(folds("1"), Err("at least 2 folds".into()));
        assert!(folds("-3").is_err());
        assert_eq!(tip_point(" 0, 0.1 ,-0.2"), Ok(Vector3::new(0.0, 0.1, -0.2)));
        for bad in ["0,0", "0,0,0,0", "0,nan,0", "a,b,c"] {
            assert!(tip_point(bad).is_err(), "{bad}");
        }
        assert_eq!(tool_frame("0,0,0.25"), Ok([0.0, 0.0, 0.25, 0.0, 0.0, 0.0]));
        assert_eq!(
            tool_frame("1,2,3,0.1,-0.2,0.3"),
            Ok([1.0, 2.0, 3.0, 0.1, -0.2, 0.3])
        );
        for bad in ["0,0", "0,0,0,0", "0,0,0,0,0", "0,nan,0", "0,0,0,0,0,inf"] {
            assert!(tool_frame(bad).is_err(), "{bad}");
        }
        let t = tilt("3:0.001").unwrap();
        assert_eq!((t.joint, t.beta), (3, 0.001));
        for bad in ["0:0.1", "3", "3:inf", "x:0.1"] {
            assert!(tilt(bad).is_err(), "{bad}");
        }
        assert_eq!(error_sizes("0.5, 0.002"), Ok([0.5, 0.002]));
        assert_eq!(error_sizes("0,0"), Ok([0.0, 0.0]));
        for bad in ["0.5", "0.5,0.002,1", "-1,0.002", "0.5,nan", "a,b"] {
            assert!(error_sizes(bad).is_err(), "{bad}");
        }
    }
}
