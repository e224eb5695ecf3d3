//! An export read back as its target reads it, before it is written.
//!
//! A URDF is read by armcal's URDF reader (whose forward kinematics equals
//! the joint origins composed as the URDF specification defines them, to
//! 1e-15 m: `host/tests/cli/urdf.rs`): at [`CONFIGURATIONS`] joint vectors
//! within the limits, the pose of the link at the measured point in the link
//! at the measurement frame must be the calibration's measured frame, to
//! [`POSITION`] and [`ANGLE`].
//!
//! A UR deltas file is evaluated with UR's own standard D-H (the type's
//! nominal plus the deltas, [`ur::dh_flange`]), a `ur_calibration` file by
//! composing its joint origins as ur_description does
//! ([`ur::description_flange`]), each parsed from the text written. At
//! [`CONFIGURATIONS`] joint vectors spread over every joint's full turn:
//!
//! - the flange the file gives must be the calibration's flange (the
//!   calibrated arm with the robot's nominal flange frame,
//!   [`crate::apply::working_tool`]: the measured tool's offset left out),
//!   its origin to [`POSITION`] and its z axis (the last joint's axis) to
//!   [`ANGLE`]; UR's flange frame may be turned about that axis from the
//!   model's flange frame only by a constant angle;
//! - the flange composed with the TCP the file states must be the measured
//!   (or working) frame of the calibration, to the same bounds.
//!
//! Frames: everything in the UR base frame (`base_link_inertia`); m and rad.
//! The bounds are far below a tracker's noise (tens of µm) and far above the
//! rounding of the composition (1e-13 m on the real factory calibrations,
//! whose D-H `d` reach hundreds of metres).

use armcal_shared::{Calibration, JointType, Robot};
use nalgebra::Vector3;

use crate::io::ur::{self, DhDeltas, JOINTS, UrExport};
use crate::io::urdf::{self, ChainSpec, Pose};

/// How far the file's flange or TCP may be from the calibration's, m.
pub const POSITION: f64 = 1e-6;

/// How far their axes may turn from the calibration's, rad.
pub const ANGLE: f64 = 1e-6;

/// The number of joint vectors the export is read back at.
pub const CONFIGURATIONS: usize = 25;

/// [`CONFIGURATIONS`] joint vectors spread over `(−π, π]` on every joint
/// (a low-discrepancy sequence: the same vectors every run, no two alike).
pub fn configurations() -> Vec<[f64; JOINTS]> {
    // The fractional parts of multiples of the square roots of six primes.
    let steps = [2f64, 3.0, 5.0, 7.0, 11.0, 13.0].map(f64::sqrt);
    (1..=CONFIGURATIONS)
        .map(|i| {
            steps.map(|s| {
                let u = (i as f64 * s).fract();
                std::f64::consts::PI * (2.0 * u - 1.0)
            })
        })
        .collect()
}

/// The deltas file `text` as the controller reads it: the type's nominal D-H
/// `nominal` plus the deltas parsed from it.
pub fn deltas_reader<'a>(
    text: &str,
    nominal: &'a Robot<f64>,
) -> anyhow::Result<impl Fn(&[f64; JOINTS]) -> Pose + 'a> {
    let deltas: DhDeltas = ur::parse_deltas(text, "the deltas written")
        .map_err(|e| anyhow::anyhow!("the file written does not read back: {e}"))?;
    Ok(move |q: &[f64; JOINTS]| ur::dh_flange(nominal, &deltas, q))
}

/// The `ur_calibration` file `text` as ur_description reads it.
pub fn description_reader(text: &str) -> anyhow::Result<impl Fn(&[f64; JOINTS]) -> Pose> {
    let origins = ur::parse_ur_description(text, "the ur_calibration file written")
        .map_err(|e| anyhow::anyhow!("the file written does not read back: {e}"))?;
    Ok(move |q: &[f64; JOINTS]| ur::description_flange(&origins, q))
}

/// Checks the flange `file_flange` gives (in the UR base frame) and `export`'s
/// TCP against the calibrated `arm` (its tool at the robot's flange) and
/// `measured` (the same chain with the measured or working tool); the
/// worst difference found, as a sentence, when one exceeds the bounds.
pub fn check(
    export: &UrExport,
    arm: &Robot<f64>,
    measured: &Robot<f64>,
    file_flange: impl Fn(&[f64; JOINTS]) -> Pose,
) -> Result<(), String> {
    // Both chains in the UR base frame: the model's base left out, then the
    // UR base frame in the model's frame 0.
    let in_ur = export.ur_base.inverse() * arm.base.isometry().inverse();
    let mut worst = [0.0f64; 4];
    let mut turn: Option<Pose> = None;
    for q in configurations() {
        let flange = in_ur * arm.forward(&q).map_err(|e| e.to_string())?;
        let frame = in_ur * measured.forward(&q).map_err(|e| e.to_string())?;
        let file = file_flange(&q);
        let origin = (file.translation.vector - flange.translation.vector).norm();
        let axis = angle(
            &(file.rotation * Vector3::z()),
            &(flange.rotation * Vector3::z()),
        );
        // UR's flange frame about the axis: a constant turn from the model's.
        let relative = flange.inverse() * file;
        let about = match turn {
            None => {
                turn = Some(relative);
                0.0
            }
            Some(first) => (first.rotation.inverse() * relative.rotation).angle(),
        };
        let tcp = file * export.tcp;
        let tcp_origin = (tcp.translation.vector - frame.translation.vector).norm();
        let tcp_angle = (tcp.rotation.inverse() * frame.rotation).angle();
        for (w, x) in worst
            .iter_mut()
            .zip([origin, axis.max(about), tcp_origin, tcp_angle])
        {
            *w = w.max(x);
        }
    }
    let [origin, axis, tcp_origin, tcp_angle] = worst;
    if origin > POSITION || axis > ANGLE || tcp_origin > POSITION || tcp_angle > ANGLE {
        return Err(format!(
            "the file read back does not give the calibrated robot: its flange is {origin:.3e} m and {axis:.3e} rad from the calibration's, its TCP {tcp_origin:.3e} m and {tcp_angle:.3e} rad from the measured frame, at worst over {CONFIGURATIONS} configurations (bounds {POSITION:e} m, {ANGLE:e} rad)"
        ));
    }
    Ok(())
}

/// The angle between two unit vectors, accurate near 0 (atan2 of the cross
/// and dot products, not acos).
fn angle(u: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
    u.cross(v).norm().atan2(u.dot(v))
}

/// Checks the URDF `exported` (written from `cal`, the geometry it holds)
/// read back: the measured point's link in the measurement frame's link is
/// `cal`'s measured frame at every configuration (see the module header);
/// the worst difference, as a sentence, when it is not.
pub fn check_urdf(exported: &urdf::export::Exported, cal: &Calibration) -> anyhow::Result<()> {
    let parsed = urdf::parse(&exported.text, "the URDF written")
        .map_err(|e| anyhow::anyhow!("the file written does not read back: {e}"))?;
    let links = &exported.links;
    let chain = ChainSpec {
        base_link: Some(links.base.clone()),
        tip_link: Some(links.measured_point.clone()),
        tip_point: None,
    };
    let converted = parsed
        .convert(&chain)
        .map_err(|e| anyhow::anyhow!("the file written does not read back: {e}"))?;
    let frame = parsed
        .joints
        .iter()
        .find(|j| parsed.links[j.child].name == links.measurement_frame)
        .map(|j| j.origin)
        .ok_or_else(|| {
            anyhow::anyhow!("the URDF written has no link {}", links.measurement_frame)
        })?;
    let calibrated = cal.calibrated();
    let read = converted.robot;
    let mut worst = (0.0f64, 0.0f64);
    let angles = configurations();
    for q in angles.iter().map(|a| within_limits(&calibrated, a)) {
        let want = calibrated.forward(&q)?;
        let got = frame.inverse() * read.forward(&q)?;
        worst.0 = worst
            .0
            .max((got.translation.vector - want.translation.vector).norm());
        worst.1 = worst
            .1
            .max((got.rotation.inverse() * want.rotation).angle());
    }
    if worst.0 > POSITION || worst.1 > ANGLE {
        anyhow::bail!(
            "the URDF read back does not give the calibrated robot: its measured point is {:.3e} m and {:.3e} rad from the calibration's, at worst over {CONFIGURATIONS} configurations (bounds {POSITION:e} m, {ANGLE:e} rad); nothing written",
            worst.0,
            worst.1
        );
    }
    Ok(())
}

/// The joint vector of `robot` with `angles` (each in `(−π, π]`) mapped
/// into each joint's limits (a prismatic joint without limits: within ±1 m).
fn within_limits(robot: &Robot<f64>, angles: &[f64; JOINTS]) -> Vec<f64> {
    robot
        .links
        .iter()
        .enumerate()
        .map(|(k, l)| {
            // Six values cycle over longer chains, shifted per pass.
            let u = (angles[k % JOINTS] / std::f64::consts::PI + 1.0 + 0.37 * (k / JOINTS) as f64)
                .rem_euclid(2.0)
                / 2.0;
            match (l.limits, l.joint) {
                (Some([lo, hi]), _) => lo + u * (hi - lo),
                (None, JointType::Revolute) => std::f64::consts::PI * (2.0 * u - 1.0),
                (None, JointType::Prismatic) => 2.0 * u - 1.0,
            }
        })
        .collect()
}
