//! The identification from constraints alone (unknown fixed points and known
//! distances, no coordinate measured) on simulated ball-socket sessions: a
//! PUMA and a UR5e with random ±1 mm / ±1 mrad errors in every joint and tool
//! parameter, three sockets tied by their three distances, and one plane
//! touched by the ball.

use armcal_shared::effects::{Effect, EffectModel};
use armcal_shared::{Param, Robot};
use nalgebra::{Point3, Vector3};

use crate::calibration::fit::{FitRequest, FullFit, FullOptions, Status, full_params};
use crate::calibration::simulate::{self, SocketSession};
use crate::io::model_file::load_model;
use crate::session::constraints::{
    Constraints, DEFAULT_DISTANCE_STD, Distance, FixedPoint, TouchedPlane,
};

/// The true robot (nominal with random ±1 mm / ±1 mrad errors in every
/// parameter these data can separate: the base, which they cannot see, and the
/// joint parameters a rigid motion of the base frame or parallel axes absorb
/// are left nominal), a session of `per_socket` contacts with each of three
/// sockets, and the constraints a user would write for it: the three points
/// and their distances.
fn session(
    model: &str,
    seed: u64,
    per_socket: usize,
    contact_noise: f64,
) -> (Robot<f64>, Robot<f64>, SocketSession, Constraints) {
    session_of(
        model,
        seed,
        &Kinds::alike(per_socket, contact_noise),
        Vector3::zeros(),
    )
}

/// How a session contacts its sockets and its plane: contacts per socket and
/// their noise (m, per axis), touches of the plane and their noise (m, along
/// the normal).
struct Kinds {
    per_socket: usize,
    point_noise: f64,
    touches: usize,
    plane_noise: f64,
}

impl Kinds {
    /// `per_socket` contacts of each socket and as many touches of the
    /// plane, each with the noise `noise` (m).
    fn alike(per_socket: usize, noise: f64) -> Self {
        Self {
            per_socket,
            point_noise: noise,
            touches: per_socket,
            plane_noise: noise,
        }
    }
}

/// [`session`] with each kind of contact drawn as `kinds` says, the plate
/// touched by a probe `offset` (m, tool frame) off the ball's centre.
fn session_of(
    model: &str,
    seed: u64,
    kinds: &Kinds,
    offset: Vector3<f64>,
) -> (Robot<f64>, Robot<f64>, SocketSession, Constraints) {
    let exact = Kinds {
        point_noise: 0.0,
        plane_noise: 0.0,
        ..*kinds
    };
    let nominal = load_model(model).expect("built-in model").robot;
    // Which parameters exact data of such a session separate.
    let (probe, c) = draw_kinds(&nominal, seed, &exact, Vector3::zeros());
    let held: Vec<Param> = fit(&nominal, &probe, &c, &FullOptions::least_squares())
        .params
        .iter()
        .filter(|p| matches!(p.status, Status::Fixed { .. }))
        .map(|p| p.param)
        .collect();
    let params: Vec<Param> = full_params(&nominal, false)
        .into_iter()
        .filter(|p| !held.contains(p))
        .collect();
    let mut rng = simulate::rng(seed + 1000);
    let (truth, _) = simulate::with_random_errors(&nominal, &params, 1e-3, 1e-3, &mut rng);
    let (session, constraints) = draw_kinds(&truth, seed, kinds, offset);
    (nominal, truth, session, constraints)
}

/// The plane of the sessions: through a reachable point, a random normal.
fn plane_of(truth: &Robot<f64>, rng: &mut rand::rngs::StdRng) -> (Point3<f64>, Vector3<f64>) {
    let kin = truth.prepare();
    let q = simulate::random_configuration(truth, rng);
    let centre = Point3::from(kin.forward(&q).expect("joint count").translation.vector);
    let n = Vector3::new(0.3, -0.5, 0.8).normalize();
    (centre, n)
}

/// A session of `truth` with three sockets at random reachable points and
/// the touches of one plane, each kind of contact as `kinds` says; the
/// plane touched by a probe `probe` (m, tool frame) off the ball's centre
/// (zero: the ball itself).
fn draw_kinds(
    truth: &Robot<f64>,
    seed: u64,
    kinds: &Kinds,
    probe: Vector3<f64>,
) -> (SocketSession, Constraints) {
    let &Kinds {
        per_socket,
        point_noise,
        touches,
        plane_noise,
    } = kinds;
    let mut rng = simulate::rng(seed);
    let kin = truth.prepare();
    let sockets: Vec<Point3<f64>> = simulate::random_configurations(truth, 3, &mut rng)
        .iter()
        .map(|q| Point3::from(kin.forward(q).expect("joint count").translation.vector))
        .collect();
    let mut session = simulate::socket_session(truth, &sockets, per_socket, point_noise, &mut rng)
        .expect("every socket is reached");
    let (centre, normal) = plane_of(truth, &mut rng);
    let mut prober = truth.clone();
    prober.tool.xyz += probe;
    session.observations.extend(
        simulate::plane_touches(
            &prober,
            (centre, normal, 0.1),
            0,
            touches,
            plane_noise,
            &mut rng,
        )
        .expect("the plane is reached"),
    );
    session.plane = Some((centre, normal));
    let points = (0..3)
        .map(|k| FixedPoint {
            name: format!("socket.{k}"),
            first: (0, 0),
            rows: per_socket,
        })
        .collect();
    let distances = [[0, 1], [1, 2], [0, 2]]
        .into_iter()
        .map(|[a, b]| Distance {
            points: [a, b],
            length: (sockets[a] - sockets[b]).norm(),
            std: DEFAULT_DISTANCE_STD,
            line: 0,
        })
        .collect();
    let planes = vec![TouchedPlane {
        name: "plate".into(),
        first: (0, 0),
        rows: touches,
    }];
    (
        session,
        Constraints {
            points,
            planes,
            distances,
        },
    )
}

fn fit(nominal: &Robot<f64>, s: &SocketSession, c: &Constraints, options: &FullOptions) -> FullFit {
    FitRequest::new(nominal, &s.observations, options)
        .constrained(c)
        .run()
        .expect("fits")
}

/// Every identified parameter's error against the truth, in its standard errors.
fn worst_error_in_std(fit: &FullFit, truth: &Robot<f64>) -> f64 {
    fit.params
        .iter()
        .filter_map(|p| match p.status {
            Status::Identified { std } => {
                let e = fit.calibrated.param(p.param).unwrap() - truth.param(p.param).unwrap();
                Some(e.abs() / std)
            }
            Status::Fixed { .. } => None,
        })
        .fold(0.0, f64::max)
}

#[test]
fn exact_socket_sessions_recover_the_true_robot() {
    for model in ["puma560", "ur5e"] {
        let (nominal, truth, s, c) = session(model, 7, 25, 0.0);
        let options = FullOptions {
            position_noise: 5e-5,
            ..FullOptions::least_squares()
        };
        let fit = fit(&nominal, &s, &c, &options);
        assert!(fit.converged, "{model}");
        let mut identified = 0;
        let mut worst: f64 = 0.0;
        for p in &fit.params {
            if let Status::Identified { .. } = p.status {
                let e = fit.calibrated.param(p.param).unwrap() - truth.param(p.param).unwrap();
                assert!(e.abs() < 1e-9, "{model} {}: {e:e}", p.param);
                identified += 1;
                worst = worst.max(e.abs());
            }
        }
        eprintln!("{model}, exact: {identified} parameters identified, worst error {worst:.1e}");
        // Every joint and tool parameter but those a motion of the base frame
        // (θ1, s1), parallel axes or the tool point make inseparable, as with a
        // tracker measuring positions (4M + 3), less the six of the base.
        assert!(identified >= 4 * nominal.dof() - 6, "{model}: {identified}");
        for (p, truth) in fit.points.iter().zip(&s.sockets) {
            assert!((p.position - truth).norm() < 1e-9, "{model} {}", p.name);
        }
        for d in &fit.distance_residuals {
            assert!(d.abs() < 1e-9, "{model}: {d:e}");
        }
        let (centre, normal) = s.plane.unwrap();
        let plane = &fit.planes[0];
        let sign = plane.normal.dot(&normal).signum();
        assert!((plane.normal * sign - normal).norm() < 1e-9, "{model}");
        assert!(
            (plane.offset * sign - normal.dot(&centre.coords)).abs() < 1e-9,
            "{model}"
        );
        // The base is named unobservable, with the reason.
        for p in fit
            .params
            .iter()
            .filter(|p| matches!(p.param, Param::Base(_)))
        {
            match &p.status {
                Status::Fixed { reason } => assert!(reason.contains("not observable"), "{reason}"),
                s => panic!("{model} {}: {s:?}", p.param),
            }
        }
    }
}

#[test]
fn noisy_socket_sessions_recover_the_truth_within_four_standard_errors() {
    for (model, seed) in [("puma560", 11), ("ur5e", 12)] {
        let (nominal, truth, s, c) = session(model, seed, 30, 5e-5);
        let options = FullOptions {
            position_noise: 5e-5,
            ..FullOptions::least_squares()
        };
        let fit = fit(&nominal, &s, &c, &options);
        assert!(fit.converged, "{model}");
        let worst = worst_error_in_std(&fit, &truth);
        eprintln!("{model}, 0.05 mm contacts: worst error {worst:.2} standard errors");
        assert!(
            worst < 4.0,
            "{model}: worst error {worst:.2} standard errors"
        );
        // The contact noise is what the residuals show.
        let shown = fit.position_rms / 3f64.sqrt();
        assert!((shown / 5e-5 - 1.0).abs() < 0.3, "{model}: {shown:e}");
    }
}

/// RMS distance, over 200 random configurations, between the tool points of
/// the fitted and the true robot, m.
fn tool_point_rms(fit: &FullFit, truth: &Robot<f64>) -> f64 {
    let mut rng = simulate::rng(99);
    let (fitted, truth_kin) = (fit.calibrated.prepare(), truth.prepare());
    let configurations = simulate::random_configurations(truth, 200, &mut rng);
    let sum: f64 = configurations
        .iter()
        .map(|q| {
            let a = fitted.forward(q).expect("joint count").translation.vector;
            let b = truth_kin
                .forward(q)
                .expect("joint count")
                .translation
                .vector;
            (a - b).norm_squared()
        })
        .sum();
    (sum / configurations.len() as f64).sqrt()
}

/// A ball seated in sockets (0.02 mm per axis) and a probe touching a plate
/// (0.2 mm along its normal) are two kinds of contact with two noises: each
/// kind's noise is estimated on its own (variance components), each within
/// three standard deviations of the truth — an estimated `σ` from a channel of
/// redundancy `r` scatters by `σ / √(2r)` — and weighing each kind by its own
/// noise identifies the robot no worse than one noise shared by both (the
/// fit of the old single channel: both kinds weighed alike; without a prior
/// its level does not move the estimate).
#[test]
fn each_kind_of_contact_gets_its_own_noise() {
    use crate::calibration::fit::noise::NoiseSource;
    use crate::session::prior::Prior;
    let kinds = Kinds {
        per_socket: 40,
        point_noise: 2e-5,
        touches: 100,
        plane_noise: 2e-4,
    };
    for (model, seed) in [("puma560", 21), ("ur5e", 22)] {
        let (nominal, truth, s, c) = session_of(model, seed, &kinds, Vector3::zeros());
        let own = fit(
            &nominal,
            &s,
            &c,
            &FullOptions {
                prior: Prior::NONE,
                ..FullOptions::default()
            },
        );
        assert!(own.converged, "{model}");
        for (noise, truth_noise, what) in [
            (own.noise.point, kinds.point_noise, "point"),
            (own.noise.plane, kinds.plane_noise, "plane"),
        ] {
            let noise = noise.expect("the session has this kind");
            assert_eq!(noise.source, NoiseSource::Estimated);
            let tolerance = 3.0 / (2.0 * noise.redundancy).sqrt();
            let relative = noise.used / truth_noise - 1.0;
            assert!(
                relative.abs() < tolerance,
                "{model} {what}: estimated {:.3e} m against {truth_noise:e} m \
                 (redundancy {:.1}, tolerance ±{tolerance:.3})",
                noise.used,
                noise.redundancy
            );
        }
        // Distances keep their stated uncertainty.
        let distance = own.noise.distance.expect("three distances");
        assert_eq!(distance.source, NoiseSource::Stated);
        assert_eq!(distance.used, DEFAULT_DISTANCE_STD);

        let shared = fit(
            &nominal,
            &s,
            &c,
            &FullOptions {
                position_noise: 1e-4,
                ..FullOptions::least_squares()
            },
        );
        assert!(shared.converged, "{model}");
        let (own_rms, shared_rms) = (
            tool_point_rms(&own, &truth),
            tool_point_rms(&shared, &truth),
        );
        eprintln!(
            "{model}: point noise {:.3e} m, plane noise {:.3e} m; tool point RMS error \
             {own_rms:.3e} m with them, {shared_rms:.3e} m with one shared noise",
            own.noise.point.unwrap().used,
            own.noise.plane.unwrap().used
        );
        assert!(
            own_rms <= shared_rms,
            "{model}: own noises {own_rms:.3e} m, one shared noise {shared_rms:.3e} m"
        );
    }
}

/// The readings a robot with the joint effects `effects` gives at the true
/// joint values `q` (each observation's, replaced): the readings `q̂` with
/// `q̂ + Δq(q̂) = q`, by fixed-point iteration (`Δq` is a few mrad and varies
/// slowly with `q̂`, so each step shrinks the error by far more than 10).
fn readings_under(truth: &Robot<f64>, effects: &[Effect<f64>], session: &mut SocketSession) {
    let model = EffectModel::new(truth.clone(), effects).expect("the effects' joints exist");
    let kinematics = truth.prepare();
    for o in &mut session.observations {
        let q = o.q.clone();
        let mut read = q.clone();
        for _ in 0..30 {
            let real = model
                .joint_values(&kinematics, truth, &read, &o.context)
                .expect("joint count");
            for j in 0..q.len() {
                read[j] = q[j] - (real[j] - read[j]);
            }
        }
        o.q = read;
    }
}

/// `armcal diagnose` reads a session without a tracker as it reads a
/// tracker's: a PUMA with random ±1 mm / ±1 mrad errors and a joint 2 that
/// yields under gravity (2·10⁻⁵ rad/(N·m): up to about 1 mrad, half a
/// millimetre at the tool) seats a ball in three sockets 40 times each and
/// touches a plate 40 times, 0.05 mm contact noise. The diagnosis names the
/// compliance of joint 2 and nothing else, estimates it within four of its
/// standard errors, and predicts the contacts held-out better than the
/// geometric calibration; on the same session without the compliance it names
/// nothing (the 1 % family-wise test).
#[test]
fn diagnose_names_a_compliance_hidden_in_a_socket_session() {
    use crate::calibration::diagnose::{Choice, DiagnoseOptions, diagnose_session};
    let kinds = Kinds {
        per_socket: 40,
        point_noise: 5e-5,
        touches: 40,
        plane_noise: 5e-5,
    };
    let (nominal, truth, geometric, c) = session_of("puma560", 31, &kinds, Vector3::zeros());
    let compliance = 2e-5;
    let hidden = Effect::JointCompliance {
        joint: 1,
        compliance,
    };
    let mut yielding = geometric.clone();
    readings_under(&truth, &[hidden], &mut yielding);
    let options = DiagnoseOptions::default();

    let d = diagnose_session(&nominal, &yielding.observations, &c, &options).expect("diagnoses");
    assert!(matches!(d.choice, Choice::Calibrated { .. }));
    let named: Vec<(&str, Vec<usize>)> = d
        .findings
        .iter()
        .map(|f| (f.candidate.name, f.candidate.joints.clone()))
        .collect();
    assert_eq!(
        named,
        [("joint_compliance", vec![1])],
        "{}",
        d.chosen_label()
    );
    let fitted = &d.fit.effects[0];
    let Status::Identified { std } = fitted.status[0] else {
        panic!("the compliance is identified: {:?}", fitted.status[0]);
    };
    let estimate = fitted.effect.parameter(0).expect("one parameter");
    assert!(
        (estimate - compliance).abs() < 4.0 * std,
        "compliance {estimate:e} ± {std:e} rad/(N·m), truly {compliance:e}"
    );
    let (geometric_held, extended_held) = (d.holdout.geometric, d.holdout.extended);
    eprintln!(
        "{}: compliance {estimate:.4e} ± {std:.1e} rad/(N·m); held-out RMS {:.4} mm \
         geometric, {:.4} mm with it",
        d.chosen_label(),
        geometric_held.rms * 1e3,
        extended_held.rms * 1e3
    );
    assert!(extended_held.rms < geometric_held.rms / options.min_gain);

    let rigid =
        diagnose_session(&nominal, &geometric.observations, &c, &options).expect("diagnoses");
    assert!(matches!(rigid.choice, Choice::Calibrated { .. }));
    assert!(rigid.findings.is_empty(), "{}", rigid.chosen_label());
}

/// A session that visits its sockets in turn (ten sockets, three rounds, the
/// rows in the order taken) is cross-validated with every socket located in
/// every fold: its three rows fall in three different folds of ten, though
/// they stand ten rows apart, so each fold trains on two of them. The
/// diagnosis then scores the calibrated models and chooses one, far better
/// held-out than the nominal model.
#[test]
fn a_session_visiting_its_sockets_in_turn_locates_each_in_every_fold() {
    use crate::calibration::diagnose::{Choice, DiagnoseOptions, diagnose_session};
    use crate::calibration::validation::folds::interleaved_folds;
    use crate::session::observation::Contact;
    let nominal = load_model("puma560").expect("built-in model").robot;
    let mut rng = simulate::rng(41);
    let (truth, _) = simulate::with_random_errors(
        &nominal,
        &full_params(&nominal, false),
        1e-3,
        1e-3,
        &mut rng,
    );
    let kin = truth.prepare();
    let sockets: Vec<Point3<f64>> = simulate::random_configurations(&truth, 10, &mut rng)
        .iter()
        .map(|q| Point3::from(kin.forward(q).expect("joint count").translation.vector))
        .collect();
    let session = simulate::socket_session(&truth, &sockets, 3, 5e-5, &mut rng)
        .expect("every socket is reached");
    // Round by round: socket 0, 1, …, 9, then again.
    let rows: Vec<crate::session::observation::Observation> = (0..3)
        .flat_map(|round| (0..10).map(move |k| (k, round)))
        .map(|(k, round)| session.observations[3 * k + round].clone())
        .collect();
    let contacts: Vec<Contact> = rows.iter().map(|o| o.contact).collect();
    let configurations: Vec<usize> = (0..rows.len()).collect();
    let folds = interleaved_folds(&contacts, &configurations, 10);
    for k in 0..10 {
        let mine: Vec<usize> = (0..rows.len())
            .filter(|&i| contacts[i] == Contact::Point(k))
            .map(|i| folds[i])
            .collect();
        assert_eq!(mine.len(), 3);
        assert!(
            mine[0] != mine[1] && mine[1] != mine[2] && mine[0] != mine[2],
            "{mine:?}"
        );
    }
    let c = Constraints {
        points: (0..10)
            .map(|k| FixedPoint {
                name: format!("socket.{k}"),
                first: (0, 0),
                rows: 3,
            })
            .collect(),
        planes: Vec::new(),
        distances: (0..9)
            .map(|k| Distance {
                points: [k, k + 1],
                length: (sockets[k] - sockets[k + 1]).norm(),
                std: DEFAULT_DISTANCE_STD,
                line: 0,
            })
            .collect(),
    };
    let d = diagnose_session(&nominal, &rows, &c, &DiagnoseOptions::default()).expect("diagnoses");
    assert!(d.models.len() > 1, "no calibrated model was scored");
    assert!(
        matches!(d.choice, Choice::Calibrated { .. }),
        "{}",
        d.chosen_label()
    );
    let (nominal_held, chosen_held) = (d.holdout.nominal, d.holdout.extended);
    assert!(
        chosen_held.rms < nominal_held.rms / 2.0,
        "{nominal_held:?} {chosen_held:?}"
    );
}

/// A block probed on three faces in each of two placements (no socket, no
/// distance: 40 touches per face, 0.05 mm along the normal, a UR5e with
/// ±1 mm / ±1 mrad errors), each placement's faces turned 30° from the
/// other's. Calibrated on one placement, the other's predicted touches lie on
/// their three planes far closer than the nominal model puts them, and
/// `holdout`'s table shows that flatness (and no spread or distance, which
/// such a session has not).
#[test]
fn a_probed_block_held_out_is_judged_by_its_flatness() {
    use crate::calibration::holdout::{Selection, leave_one_out};
    use crate::commands::holdout::holdout_table;
    use crate::session::measurements::Measurements;
    use nalgebra::Rotation3;

    let model = load_model("ur5e").expect("built-in model");
    let nominal = &model.robot;
    let mut rng = simulate::rng(41);
    let (truth, _) =
        simulate::with_random_errors(nominal, &full_params(nominal, false), 1e-3, 1e-3, &mut rng);
    let noise = 5e-5;
    let placement = |name: &str, turn: f64, rng: &mut rand::rngs::StdRng| {
        let (corner, _) = plane_of(&truth, rng);
        let r = Rotation3::from_euler_angles(0.2, -0.1, turn);
        let mut poses = Vec::new();
        let mut planes = Vec::new();
        for face in 0..3 {
            let normal = r * Vector3::ith(face, 1.0);
            poses.extend(
                simulate::plane_touches(&truth, (corner, normal, 0.1), face, 40, noise, rng)
                    .expect("the face is reached"),
            );
            planes.push(TouchedPlane {
                name: format!("{name}.{face}"),
                first: (0, 0),
                rows: 40,
            });
        }
        let n = poses.len();
        Measurements {
            file: format!("{name}.csv"),
            poses,
            lines: (2..2 + n).collect(),
            times: vec![None; n],
            columns_used: Vec::new(),
            columns_ignored: Vec::new(),
            warnings: Vec::new(),
            constraints: Constraints {
                planes,
                ..Constraints::default()
            },
            sessions: Vec::new(),
        }
    };
    let sessions = [
        placement("a", 0.0, &mut rng),
        placement("b", 30f64.to_radians(), &mut rng),
    ];
    // As `armcal holdout` calibrates: the model's prior, the noise estimated.
    // Without it nothing would hold the arm's scale (no distance is known),
    // and a fit shrinking the arm would flatten every plane.
    let options = crate::calibration::identify::StatedScales::default()
        .options(&model)
        .expect("no scale stated");
    let rows = leave_one_out(&model, &sessions, None, &options, Selection::Stated).expect("fits");
    for r in &rows {
        let (nominal, calibrated) = (
            r.nominal.flatness_rms().expect("planes"),
            r.calibrated.flatness_rms().expect("planes"),
        );
        eprintln!(
            "{}: flatness nominal {nominal:e} m, calibrated {calibrated:e} m, training {:e} m",
            r.file, r.training_rms
        );
        // The touches' own scatter is the noise: neither fit nor prediction
        // goes far below it (a shrunk arm would).
        assert!(
            r.training_rms > noise / 2.0,
            "{}: {:e}",
            r.file,
            r.training_rms
        );
        assert!(calibrated > noise / 2.0, "{}: {calibrated:e}", r.file);
        assert!(
            calibrated < nominal / 5.0,
            "{}: {calibrated} against {nominal}",
            r.file
        );
        assert_eq!(r.calibrated.spread_rms(), None);
        assert_eq!(r.calibrated.worst_distance_error(), None);
    }
    let reports: Vec<_> = rows.iter().map(|r| r.report(&model.units)).collect();
    let table = holdout_table(&reports, None);
    assert!(table.contains("flatness"), "{table}");
    assert!(table.contains('–'), "{table}");
}

/// The measurements a file of session `s` under constraints `c` would give.
fn measurements(s: &SocketSession, c: &Constraints) -> crate::session::measurements::Measurements {
    let n = s.observations.len();
    crate::session::measurements::Measurements {
        file: "contacts.csv".into(),
        poses: s.observations.clone(),
        lines: (2..2 + n).collect(),
        times: vec![None; n],
        columns_used: Vec::new(),
        columns_ignored: Vec::new(),
        warnings: Vec::new(),
        constraints: c.clone(),
        sessions: Vec::new(),
    }
}

/// The calibration of `data` with each kind of row weighed as `weights`
/// says (the rest chosen), the model's default prior, the plane contacts'
/// noise stated as `plane_noise` (m) and the rest estimated:
/// the RMS distance between its tool points and the true robot's at 200
/// random configurations (m: what it predicts of poses it never saw, without
/// measurement noise), and the factors it was fitted at.
fn delivered(
    model: &crate::session::model::RobotModel,
    data: &crate::session::measurements::Measurements,
    weights: &[(
        crate::session::channel::Weighed,
        super::channel_weight::ChannelWeight,
    )],
    plane_noise: f64,
    truth: &Robot<f64>,
) -> (f64, crate::session::channel::WeightFactors) {
    use super::channel_weight::ChannelWeights;
    use crate::calibration::validation::folds::DEFAULT_FOLDS;
    let mut request = ChannelWeights::chosen(DEFAULT_FOLDS);
    for &(w, c) in weights {
        request[w] = c;
    }
    let options = FullOptions {
        plane_noise: Some(crate::calibration::fit::noise::Noise {
            sigma: plane_noise,
            source: crate::calibration::fit::noise::NoiseSource::Stated,
        }),
        ..super::StatedScales::default()
            .options(model)
            .expect("no scale stated")
    };
    let fit = super::identify(
        model,
        data,
        &super::IdentifyRequest {
            weights: request,
            ..super::IdentifyRequest::new(options)
        },
    )
    .expect("fits");
    let calibrated = fit.calibrated();
    eprintln!(
        "{}",
        fit.weighting.reports(fit.full.as_ref().unwrap()).summary()
    );
    let mut rng = simulate::rng(99);
    let held = simulate::random_configurations(truth, 200, &mut rng);
    (
        crate::test_support::true_error(&calibrated, truth, &held),
        fit.weighting.factors(),
    )
}

/// `data` without its plane and its touches: the sockets alone.
fn sockets_alone(
    data: &crate::session::measurements::Measurements,
) -> crate::session::measurements::Measurements {
    let mut alone = data.clone();
    alone.poses.retain(|o| o.on_plane().is_none());
    let n = alone.poses.len();
    alone.lines.truncate(n);
    alone.times.truncate(n);
    alone.constraints.planes.clear();
    alone
}

/// A plate touched by a probe whose tip is not the ball's centre (0.3 mm off
/// it across the tool), beside three sockets the ball sits in (a UR5e,
/// ±1 mm / ±1 mrad; 20 contacts a socket and 20 touches, 0.02 mm), the
/// touches' noise stated as the probe's 0.02 mm: the touches see another
/// tool point, a bias no noise makes, and weighed by the noise stated they
/// pull the tool and the joints toward it — the calibration misses 200
/// unseen tool points of the true robot by more than from the sockets
/// alone. The plane's weight chosen on the held-out sockets is below its
/// noise's in every session, and the calibration delivers as the better of
/// the two (within a tenth: where each chooses its prior's factor). Touches
/// made with the ball itself are kept at their noise's weight every time.
#[test]
fn a_probe_off_the_ball_is_weighed_down_beside_the_sockets() {
    use super::channel_weight::ChannelWeight;
    use crate::session::channel::Weighed;
    let model = load_model("ur5e").expect("built-in model");
    let noise = 2e-5;
    let kinds = Kinds::alike(20, noise);
    for seed in 1..=4 {
        for offset in [Vector3::new(3e-4, 0.0, 0.0), Vector3::zeros()] {
            let (_, truth, s, c) = session_of("ur5e", seed, &kinds, offset);
            let data = measurements(&s, &c);
            let (chosen, factors) = delivered(&model, &data, &[], noise, &truth);
            let estimated = [(Weighed::Plane, ChannelWeight::Stated(1.0))];
            let (as_estimated, _) = delivered(&model, &data, &estimated, noise, &truth);
            let (alone, _) = delivered(&model, &sockets_alone(&data), &[], noise, &truth);
            let plane = factors[Weighed::Plane];
            eprintln!(
                "seed {seed}, probe {:.1} mm off: plane weight {plane}, delivers {:.4} mm; \
                 as estimated {:.4} mm; sockets alone {:.4} mm",
                offset.norm() * 1e3,
                chosen * 1e3,
                as_estimated * 1e3,
                alone * 1e3
            );
            if offset.norm() == 0.0 {
                assert_eq!(plane, 1.0, "seed {seed}: the ball's touches weighed down");
                continue;
            }
            assert!(
                as_estimated > alone,
                "seed {seed}: the probe's offset did no harm"
            );
            assert!(plane < 1.0, "seed {seed}: the probe's touches kept");
            assert!(
                chosen <= 1.1 * alone,
                "seed {seed}: {chosen} against {alone} alone, {as_estimated} as estimated"
            );
        }
    }
}
