//! The calibration file: what is written reads back bit for bit, and every damaged,
//! truncated, foreign or newer file is refused with its reason.

use armcal_shared::calibration::{
    FORMAT_VERSION, HEADER_LEN, MAGIC, MAX_FILE_LEN, MAX_PARAMS, OLDEST_VERSION, TargetFrame,
    model_hash,
};
use armcal_shared::compensation::Task;
use armcal_shared::effects::{Effect, MAX_EFFECTS};
use armcal_shared::ranges::{Interval, Ranges};
use armcal_shared::units::{AngleUnit, LengthUnit, Units};
use armcal_shared::{
    Calibration, CalibrationError, Convention, Frame, FrameAxis, GeometricCalibration, JointType,
    Link, LinkMass, MAX_JOINTS, Param, ParamError, Robot,
};
use nalgebra::Vector3;
use serde::Serialize;

/// A 6R arm with limits and masses and a handful of identified errors.
fn sample() -> Calibration {
    let mut links = Vec::new();
    for m in 0..6 {
        let mut l = Link::new(
            JointType::Revolute,
            0.1 * m as f64,
            0.2,
            -0.4,
            std::f64::consts::FRAC_PI_2,
        );
        l.limits = Some([-3.0, 3.0]);
        l.mass = Some(LinkMass {
            mass: 2.0 + m as f64,
            com: Vector3::new(0.01, 0.02, 0.03),
        });
        links.push(l);
    }
    let mut nominal = Robot::new(Convention::Dh, &links).unwrap();
    nominal.base = Frame {
        xyz: Vector3::new(1.0, 2.0, 0.5),
        rpy: Vector3::new(0.0, 0.1, -1.2),
    };
    nominal.gravity = Some(Vector3::new(0.0, 0.0, -9.81));
    let mut cal = Calibration::nominal(
        nominal,
        Task::Position,
        Units {
            length: LengthUnit::Mm,
            angle: AngleUnit::Deg,
        },
    );
    for (param, error) in [
        (Param::Theta(1), 1.0e-3),
        (Param::Alpha(2), -2.0e-4),
        (Param::A(3), 3.0e-4),
        (Param::Base(FrameAxis::Rz), 0.02),
        (Param::Tool(FrameAxis::Z), -1.5e-3),
    ] {
        cal.errors.push(ParamError { param, error }).unwrap();
    }
    // Identified on joints within ±1.5 rad, at 21–29 °C and 0–5 kg.
    let poses = [
        ([-1.5; 6], Some(21.0), Some(0.0)),
        ([1.5; 6], Some(29.0), Some(5.0)),
    ];
    cal.ranges = Some(Ranges::of(poses.iter().map(|(q, t, l)| (&q[..], *t, *l))));
    // The flange 80 mm out along the last axis, turned about it, as a URDF's
    // `tool0` sits beyond its last joint's frame.
    cal.flange = Frame {
        xyz: Vector3::new(0.0, 0.0, 0.08),
        rpy: Vector3::new(0.0, 0.0, 0.3),
    };
    cal
}

/// [`sample`] as `armcal diagnose` writes a calibration with an effect: an
/// encoder scale of joint 2 identified with the geometry, the expected
/// held-out error, and the geometric fallback (the geometry refitted without
/// the effect) with its own.
fn with_fallback() -> Calibration {
    let mut cal = sample();
    cal.effects
        .push(Effect::EncoderScale {
            joint: 1,
            scale: 2.5e-4,
        })
        .unwrap();
    cal.held_out = Some(3.7e-4);
    let mut errors = cal.errors.clone();
    errors.clear();
    for (param, error) in [
        (Param::Theta(1), 1.2e-3),
        (Param::A(3), 2.9e-4),
        (Param::Base(FrameAxis::Rz), 0.021),
    ] {
        errors.push(ParamError { param, error }).unwrap();
    }
    cal.geometric = Some(GeometricCalibration {
        errors,
        held_out: Some(5.6e-4),
    });
    cal
}

/// The payload of a version 4 file: a calibration without its held-out error
/// and geometric fallback.
#[derive(Serialize)]
struct PayloadV4<'a> {
    nominal: &'a Robot<f64>,
    errors: &'a [ParamError],
    orientation: bool,
    units: Units,
    effects: &'a [Effect<f64>],
    targets: TargetFrame,
    ranges: &'a Option<Ranges<f64>>,
}

/// The payload of a version 5 file: a calibration without its flange.
#[derive(Serialize)]
struct PayloadV5<'a> {
    nominal: &'a Robot<f64>,
    errors: &'a [ParamError],
    orientation: bool,
    units: Units,
    effects: &'a [Effect<f64>],
    targets: TargetFrame,
    ranges: &'a Option<Ranges<f64>>,
    held_out: Option<f64>,
    geometric: &'a Option<GeometricCalibration>,
}

/// The payload of a version 3 file: a calibration without its ranges.
#[derive(Serialize)]
struct PayloadV3<'a> {
    nominal: &'a Robot<f64>,
    errors: &'a [ParamError],
    orientation: bool,
    units: Units,
    effects: &'a [Effect<f64>],
    targets: TargetFrame,
}

/// A whole file of `version` around `payload`, as an older armcal wrote it.
fn file_of(version: u16, cal: &Calibration, payload: &[u8]) -> Vec<u8> {
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&version.to_le_bytes());
    bytes.extend_from_slice(&[cal.nominal.dof() as u8, 0]);
    bytes.extend_from_slice(&model_hash(&cal.nominal).to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    bytes.extend_from_slice(payload);
    bytes.extend_from_slice(&[0; 4]);
    reseal(&mut bytes);
    bytes
}

/// The file's bytes, through the `no_std` writer the firmware side links too.
fn bytes_of(cal: &Calibration) -> Result<Vec<u8>, CalibrationError> {
    let mut buf = vec![0u8; MAX_FILE_LEN];
    cal.encode(&mut buf).map(|b| b.to_vec())
}

/// Re-seals a file after editing its header, so that the check under test, not the
/// CRC, is what refuses it.
fn reseal(bytes: &mut [u8]) {
    let n = bytes.len() - 4;
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn round_trip_is_exact() {
    let cal = sample();
    let bytes = bytes_of(&cal).unwrap();
    assert_eq!(&bytes[..8], &MAGIC);
    assert_eq!(Calibration::decode(&bytes).unwrap(), cal);
    // The calibrated model carries the errors.
    let calibrated = cal.calibrated();
    assert_eq!(
        calibrated.param(Param::Theta(1)).unwrap(),
        cal.nominal.links[1].theta + 1.0e-3
    );
    assert_eq!(
        calibrated.param(Param::Base(FrameAxis::Rz)).unwrap(),
        -1.2 + 0.02
    );
}

/// The largest calibration: the most joints, every parameter identified with
/// values that need all eight bytes, the most effects (the largest, gear
/// harmonics), every range recorded, the held-out error known, and the
/// geometric fallback identifying every parameter again.
#[test]
fn the_largest_calibration_fits_the_loader_buffer() {
    let mut cal = sample();
    let link = cal.nominal.links[0];
    cal.nominal = Robot::new(Convention::Mdh, &[link; MAX_JOINTS]).unwrap();
    let wide = [-1.234_567_890_123; MAX_JOINTS];
    cal.ranges = Some(Ranges::of([(&wide[..], Some(21.1), Some(0.3))]));
    for joint in 0..MAX_EFFECTS {
        let a = 1.234_567_890_123e-4;
        cal.effects
            .push(Effect::GearTransmission {
                joint: joint % MAX_JOINTS,
                first: [a, -a],
                second: [-a, a],
            })
            .unwrap();
    }
    cal.nominal.gravity = Some(Vector3::new(0.0, 0.0, -9.81));
    cal.errors.clear();
    let tilts = (0..MAX_JOINTS).map(Param::Beta);
    let params: Vec<Param> = cal.nominal.params().chain(tilts).collect();
    assert_eq!(params.len(), MAX_PARAMS);
    for param in params {
        // Values that need all eight bytes.
        cal.errors
            .push(ParamError {
                param,
                error: -1.234_567_890_123e-3,
            })
            .unwrap();
    }
    // The geometric fallback identifies every parameter again.
    cal.held_out = Some(1.234_567_890_123e-4);
    cal.geometric = Some(GeometricCalibration {
        errors: cal.errors.clone(),
        held_out: Some(2.345_678_901_234e-4),
    });
    let bytes = bytes_of(&cal).unwrap();
    assert!(bytes.len() <= MAX_FILE_LEN, "{} bytes", bytes.len());
    assert_eq!(Calibration::decode(&bytes).unwrap(), cal);
    println!(
        "the largest calibration: {} bytes of {MAX_FILE_LEN}",
        bytes.len()
    );
}

/// CRC-32 detects every error burst of up to 32 bits, so every single-byte change
/// anywhere in the file must be refused, whatever the byte becomes.
#[test]
fn every_single_byte_corruption_is_refused() {
    let bytes = bytes_of(&with_fallback()).unwrap();
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff, 0x5a] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            assert!(
                Calibration::decode(&bad).is_err(),
                "byte {i} ^ {flip:#x} accepted"
            );
        }
    }
}

#[test]
fn every_truncation_is_refused_as_truncated() {
    let bytes = bytes_of(&with_fallback()).unwrap();
    for len in 0..bytes.len() {
        match Calibration::decode(&bytes[..len]) {
            Err(CalibrationError::Truncated { len: got, .. }) => assert_eq!(got, len),
            other => panic!("{len} bytes: {other:?}"),
        }
    }
    let mut long = bytes.clone();
    long.push(0);
    assert!(matches!(
        Calibration::decode(&long),
        Err(CalibrationError::TooLong { .. })
    ));
}

/// The frame of the targets is written and read back; a version 2 file (the
/// same payload without that last field) reads as targets in the world frame,
/// what version 2 meant; a version older than that is refused.
#[test]
fn the_frame_of_the_targets_and_version_2_files() {
    let mut cal = sample();
    cal.targets = TargetFrame::Base;
    let bytes = bytes_of(&cal).unwrap();
    assert_eq!(
        Calibration::decode(&bytes).unwrap().targets,
        TargetFrame::Base
    );
    // The base frame leaves the base errors out of the compensation.
    let compensated: Vec<Param> = cal.compensated_errors().map(|e| e.param).collect();
    assert_eq!(compensated.len(), cal.errors.len() - 1);
    assert!(!compensated.contains(&Param::Base(FrameAxis::Rz)));

    // Version 2: the version 3 payload without its last byte (the frame's
    // enum index), as an older armcal wrote it.
    let v3 = v3_payload(&sample());
    assert_eq!(v3.last(), Some(&0), "World is the last byte");
    let v2 = file_of(OLDEST_VERSION, &sample(), &v3[..v3.len() - 1]);
    let mut want = sample();
    want.ranges = None;
    want.flange = Frame::identity();
    assert_eq!(Calibration::decode(&v2).unwrap(), want);

    let mut older = v2.clone();
    older[8..10].copy_from_slice(&(OLDEST_VERSION - 1).to_le_bytes());
    reseal(&mut older);
    assert_eq!(
        Calibration::decode(&older),
        Err(CalibrationError::BadVersion {
            found: OLDEST_VERSION - 1
        })
    );
}

/// The postcard payload of `cal` as version 3 wrote it.
fn v3_payload(cal: &Calibration) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_FILE_LEN];
    let payload = PayloadV3 {
        nominal: &cal.nominal,
        errors: &cal.errors,
        orientation: cal.task == Task::Pose,
        units: cal.units,
        effects: &cal.effects,
        targets: cal.targets,
    };
    postcard::to_slice(&payload, &mut buf).unwrap().to_vec()
}

/// The ranges are written and read back; a version 3 file (written before
/// calibrations recorded them) reads whole, with its ranges unknown.
#[test]
fn the_ranges_and_version_3_files() {
    let mut cal = sample();
    let read = Calibration::decode(&bytes_of(&cal).unwrap()).unwrap();
    let ranges = read.ranges.as_ref().unwrap();
    assert_eq!(ranges.joints.len(), 6);
    assert_eq!(
        ranges.joints[2],
        Interval {
            min: -1.5,
            max: 1.5
        }
    );
    assert_eq!(
        ranges.temperature,
        Some(Interval {
            min: 21.0,
            max: 29.0
        })
    );
    assert_eq!(ranges.load, Some(Interval { min: 0.0, max: 5.0 }));
    cal.targets = TargetFrame::Base;
    cal.effects
        .push(Effect::ThermalExpansion {
            coefficient: 2.3e-5,
            reference: 25.0,
        })
        .unwrap();
    let v3 = file_of(3, &cal, &v3_payload(&cal));
    let old = Calibration::decode(&v3).unwrap();
    assert_eq!(old.ranges, None);
    cal.ranges = None;
    cal.flange = Frame::identity();
    assert_eq!(old, cal);
    // Not one interval per joint, or not finite: neither written nor read.
    let mut bad = sample();
    bad.ranges.as_mut().unwrap().joints.pop();
    assert_eq!(bytes_of(&bad), Err(CalibrationError::Ranges));
    let mut bad = sample();
    bad.ranges.as_mut().unwrap().load = Some(Interval {
        min: 5.0,
        max: f64::NAN,
    });
    assert_eq!(bytes_of(&bad), Err(CalibrationError::Ranges));
}

#[test]
fn foreign_and_newer_files_are_refused_with_their_reason() {
    let bytes = bytes_of(&sample()).unwrap();
    let foreign = b"q1,q2,q3,x,y,z\n0,0,0,1,2,3\n0,0,0,1,2,3\n0,0,0,1,2,3\n".to_vec();
    assert_eq!(
        Calibration::decode(&foreign),
        Err(CalibrationError::BadMagic)
    );

    let mut newer = bytes.clone();
    newer[8..10].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    reseal(&mut newer);
    let err = Calibration::decode(&newer).unwrap_err();
    assert_eq!(
        err,
        CalibrationError::NewerVersion {
            found: FORMAT_VERSION + 1
        }
    );
    assert!(err.to_string().contains("newer"));

    let mut joints = bytes.clone();
    joints[10] = 7;
    reseal(&mut joints);
    assert_eq!(
        Calibration::decode(&joints),
        Err(CalibrationError::JointCount {
            header: 7,
            model: 6
        })
    );

    let mut hash = bytes.clone();
    hash[12] ^= 1;
    reseal(&mut hash);
    assert!(matches!(
        Calibration::decode(&hash),
        Err(CalibrationError::ModelHash { .. })
    ));
}

#[test]
fn non_finite_and_unknown_parameters_are_not_written() {
    let mut cal = sample();
    cal.errors[0].error = f64::NAN;
    assert_eq!(bytes_of(&cal), Err(CalibrationError::NonFinite));
    let mut cal = sample();
    cal.errors
        .push(ParamError {
            param: Param::S(6),
            error: 0.0,
        })
        .unwrap();
    assert_eq!(
        bytes_of(&cal),
        Err(CalibrationError::UnknownParam { param: Param::S(6) })
    );
    let mut cal = sample();
    cal.nominal.links[2].a = f64::INFINITY;
    assert_eq!(bytes_of(&cal), Err(CalibrationError::NonFinite));
}

/// The reference temperature of a thermal expansion is a value of the file
/// too, though not a parameter of the effect: not finite, it is neither
/// written nor read (found by the `calibration_decode` fuzz target).
#[test]
fn a_non_finite_thermal_reference_is_refused() {
    let mut cal = sample();
    let thermal = |reference| Effect::ThermalExpansion {
        coefficient: 2.3e-5,
        reference,
    };
    cal.effects.push(thermal(20.0)).unwrap();
    let good = bytes_of(&cal).unwrap();
    for reference in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        cal.effects[0] = thermal(reference);
        assert_eq!(bytes_of(&cal), Err(CalibrationError::NonFinite));
        // The same file with the reference's eight bytes replaced, resealed.
        let at = good
            .windows(8)
            .position(|w| w == 20.0f64.to_le_bytes())
            .unwrap();
        let mut bytes = good.clone();
        bytes[at..at + 8].copy_from_slice(&reference.to_le_bytes());
        reseal(&mut bytes);
        assert_eq!(
            Calibration::decode(&bytes),
            Err(CalibrationError::NonFinite)
        );
    }
}

#[test]
fn model_hash_tells_models_apart() {
    let cal = sample();
    let mut other = cal.nominal.clone();
    other.links[4].s += 1e-12;
    assert_ne!(model_hash(&cal.nominal), model_hash(&other));
    let bytes = bytes_of(&cal).unwrap();
    assert_eq!(&bytes[12..20], &model_hash(&cal.nominal).to_le_bytes());
    assert!(bytes.len() > HEADER_LEN);
}

/// Version 6: the expected held-out error, the geometric fallback (since
/// version 5) and the flange are written and read back bit for bit; the
/// fallback as a calibration of its own has the fallback's errors and
/// held-out error, no effects and the calibration's flange.
#[test]
fn the_held_out_error_and_the_geometric_fallback() {
    let cal = with_fallback();
    let bytes = bytes_of(&cal).unwrap();
    assert_eq!(&bytes[8..10], &6u16.to_le_bytes());
    let read = Calibration::decode(&bytes).unwrap();
    assert_eq!(read, cal);
    assert_eq!(read.held_out, Some(3.7e-4));
    let geometric = read.geometric_only().unwrap();
    assert!(geometric.effects.is_empty());
    assert_eq!(geometric.geometric, None);
    assert_eq!(geometric.held_out, Some(5.6e-4));
    assert_eq!(&geometric.errors, &cal.geometric.as_ref().unwrap().errors);
    assert_eq!(
        (geometric.nominal, geometric.units, geometric.ranges),
        (cal.nominal.clone(), cal.units, cal.ranges.clone())
    );
    assert_eq!(geometric.flange, cal.flange);
    // Nothing to fall back to without a fallback.
    assert_eq!(sample().geometric_only(), None);
    // Unknown held-out errors are written and read as unknown.
    let mut unknown = with_fallback();
    unknown.held_out = None;
    unknown.geometric.as_mut().unwrap().held_out = None;
    assert_eq!(
        Calibration::decode(&bytes_of(&unknown).unwrap()).unwrap(),
        unknown
    );
}

/// A version 4 file (written before calibrations carried their held-out
/// error and fallback) reads whole, with both unknown: a calibration with
/// effects then has no geometric fallback.
#[test]
fn version_4_files() {
    let mut cal = with_fallback();
    let mut buf = vec![0u8; MAX_FILE_LEN];
    let payload = PayloadV4 {
        nominal: &cal.nominal,
        errors: &cal.errors,
        orientation: cal.task == Task::Pose,
        units: cal.units,
        effects: &cal.effects,
        targets: cal.targets,
        ranges: &cal.ranges,
    };
    let payload = postcard::to_slice(&payload, &mut buf).unwrap().to_vec();
    let v4 = file_of(4, &cal, &payload);
    let old = Calibration::decode(&v4).unwrap();
    assert_eq!((old.held_out, old.geometric.is_some()), (None, false));
    assert_eq!(old.geometric_only(), None);
    cal.held_out = None;
    cal.geometric = None;
    cal.flange = Frame::identity();
    assert_eq!(old, cal);
    // The version 6 payload is the version 4 payload and the added fields.
    let v6 = bytes_of(&with_fallback()).unwrap();
    assert_eq!(&v6[HEADER_LEN..HEADER_LEN + payload.len()], &payload[..]);
}

/// A version 5 file (written before calibrations carried their flange) reads
/// whole with the flange at the last link's frame, where a model file's
/// `[tool]` and every working tool were then given.
#[test]
fn version_5_files() {
    let mut cal = with_fallback();
    let mut buf = vec![0u8; MAX_FILE_LEN];
    let payload = PayloadV5 {
        nominal: &cal.nominal,
        errors: &cal.errors,
        orientation: cal.task == Task::Pose,
        units: cal.units,
        effects: &cal.effects,
        targets: cal.targets,
        ranges: &cal.ranges,
        held_out: cal.held_out,
        geometric: &cal.geometric,
    };
    let payload = postcard::to_slice(&payload, &mut buf).unwrap().to_vec();
    let old = Calibration::decode(&file_of(5, &cal, &payload)).unwrap();
    assert_eq!(old.flange, Frame::identity());
    cal.flange = Frame::identity();
    assert_eq!(old, cal);
    // A flange that is not finite is neither written nor read.
    cal.flange.xyz.z = f64::NAN;
    assert_eq!(bytes_of(&cal), Err(CalibrationError::NonFinite));
}

/// A fallback or held-out error that is not valid is neither written nor
/// read: errors not finite, of a parameter the model does not have or twice,
/// held-out errors not finite or negative.
#[test]
fn an_invalid_fallback_is_refused() {
    let fallback = |f: &dyn Fn(&mut Calibration)| {
        let mut cal = with_fallback();
        f(&mut cal);
        bytes_of(&cal)
    };
    fn errors(cal: &mut Calibration) -> &mut [ParamError] {
        &mut cal.geometric.as_mut().unwrap().errors
    }
    assert_eq!(
        fallback(&|c| errors(c)[1].error = f64::NAN),
        Err(CalibrationError::NonFinite)
    );
    assert_eq!(
        fallback(&|c| errors(c)[1].param = Param::S(6)),
        Err(CalibrationError::UnknownParam { param: Param::S(6) })
    );
    assert_eq!(
        fallback(&|c| errors(c)[1].param = Param::Theta(1)),
        Err(CalibrationError::DuplicateParam {
            param: Param::Theta(1)
        })
    );
    assert_eq!(
        fallback(&|c| c.held_out = Some(f64::INFINITY)),
        Err(CalibrationError::NonFinite)
    );
    assert_eq!(
        fallback(&|c| c.geometric.as_mut().unwrap().held_out = Some(-1e-4)),
        Err(CalibrationError::HeldOut)
    );
    // The same refused on read: a good file with a value's eight bytes
    // replaced, resealed.
    let good = bytes_of(&with_fallback()).unwrap();
    for (value, bad, why) in [
        (2.9e-4f64, f64::NAN, CalibrationError::NonFinite),
        (5.6e-4, f64::NEG_INFINITY, CalibrationError::NonFinite),
        (3.7e-4, -3.7e-4, CalibrationError::HeldOut),
        (5.6e-4, -5.6e-4, CalibrationError::HeldOut),
    ] {
        let at = good
            .windows(8)
            .position(|w| w == value.to_le_bytes())
            .unwrap();
        let mut bytes = good.clone();
        bytes[at..at + 8].copy_from_slice(&bad.to_le_bytes());
        reseal(&mut bytes);
        assert_eq!(Calibration::decode(&bytes), Err(why), "{value} as {bad}");
    }
    // A fallback's parameter the model does not have: joint 2's θ error
    // renamed to joint 7's (its index byte, after the variant's).
    let theta = Param::Theta(1);
    let mut bytes = good.clone();
    let bytes_of_error = |e: &ParamError| {
        let mut buf = [0u8; 32];
        postcard::to_slice(e, &mut buf).unwrap().to_vec()
    };
    let name = bytes_of_error(&ParamError {
        param: theta,
        error: 1.2e-3,
    });
    let at = bytes.windows(name.len()).position(|w| w == name).unwrap();
    let renamed = ParamError {
        param: Param::Theta(6),
        error: 1.2e-3,
    };
    let other = bytes_of_error(&renamed);
    assert_eq!(other.len(), name.len());
    bytes[at..at + name.len()].copy_from_slice(&other);
    reseal(&mut bytes);
    assert_eq!(
        Calibration::decode(&bytes),
        Err(CalibrationError::UnknownParam {
            param: Param::Theta(6)
        })
    );
}

/// A link's mass is not negative (a mass fitted to torques of the wrong
/// sign can be): such a calibration is neither written nor read.
#[test]
fn a_negative_mass_is_neither_written_nor_read() {
    let mut cal = sample();
    cal.nominal.links[2].mass = Some(armcal_shared::LinkMass {
        mass: 3.217,
        com: nalgebra::Vector3::new(0.1, 0.0, 0.0),
    });
    let good = bytes_of(&cal).unwrap();
    assert_eq!(Calibration::decode(&good).unwrap(), cal);
    cal.nominal.links[2].mass.as_mut().unwrap().mass = -3.87;
    assert_eq!(
        bytes_of(&cal),
        Err(CalibrationError::NegativeMass { link: 2 })
    );
    // The same bytes as a good file's, the mass negated, the header's
    // model hash that of the model so changed and the file sealed again:
    // refused when read.
    let mut bytes = good.clone();
    let at = bytes
        .windows(8)
        .position(|w| w == 3.217f64.to_le_bytes())
        .expect("the mass's bytes");
    bytes[at..at + 8].copy_from_slice(&(-3.87f64).to_le_bytes());
    bytes[12..20].copy_from_slice(&model_hash(&cal.nominal).to_le_bytes());
    reseal(&mut bytes);
    assert_eq!(
        Calibration::decode(&bytes),
        Err(CalibrationError::NegativeMass { link: 2 })
    );
}
