//! The candidate extensions of the geometric model: every effect the data can
//! show. Per joint a joint compliance (when the joint carries a gravity torque),
//! gear-transmission harmonics (revolute joints), backlash (when the joint
//! approaches from both sides) and an encoder-scale error; thermal expansion
//! when the temperature varies by more than 1 °C; a Hayati tilt for each pair of
//! nominally parallel consecutive axes. Effect parameters start at zero.

use armcal_shared::effects::{Effect, gravity_torques};
use armcal_shared::{Convention, JointType, Param, Robot};

use crate::cancel::Cancel;
use crate::session::rows::Rows;

/// A candidate extension of the geometric model.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// The effect name of `docs/file-formats.md` §6.
    pub name: &'static str,
    /// Its joints, 0-based.
    pub joints: Vec<usize>,
    /// The effect to fit (parameters start at zero), if any.
    pub effect: Option<Effect<f64>>,
    /// Extra geometric parameters (Hayati tilts), if any.
    pub extra: Vec<Param>,
}

impl Candidate {
    /// Its joints as a reader counts them, `"2, 3"`, or `"all"` for thermal expansion.
    pub fn joints_label(&self) -> String {
        joints_label(self.joints.iter().map(|j| j + 1))
    }

    /// Whether `effect` is this candidate's effect (the same kind at the same
    /// joint), whatever its parameters' values.
    pub fn is(&self, effect: &Effect<f64>) -> bool {
        self.effect
            .is_some_and(|c| c.name() == effect.name() && c.joint() == effect.joint())
    }

    /// Parameters the candidate adds.
    pub fn parameter_count(&self) -> usize {
        self.effect.map_or(0, |e| e.parameter_count()) + self.extra.len()
    }
}

/// `2, 3`, or `all` for none: joints counted from 1 as the summaries and
/// the HTML page name an effect's.
pub fn joints_label(joints: impl IntoIterator<Item = usize>) -> String {
    let joints: Vec<String> = joints.into_iter().map(|j| j.to_string()).collect();
    if joints.is_empty() {
        "all".into()
    } else {
        joints.join(", ")
    }
}

/// Each candidate's own columns in a linearisation whose columns after the
/// fit's `fitted` ones are every candidate's extra parameters, then every
/// candidate's effect parameters, both in the order of `candidates` (as
/// [`crate::calibration::fit::linearize`] lays out its `extra` and
/// `effects`, given those of every candidate in turn).
pub fn own_columns(candidates: &[&Candidate], fitted: usize) -> Vec<Vec<usize>> {
    let extras: usize = candidates.iter().map(|c| c.extra.len()).sum();
    let (mut extra_at, mut effect_at) = (fitted, fitted + extras);
    candidates
        .iter()
        .map(|c| {
            let mut own: Vec<usize> = (extra_at..extra_at + c.extra.len()).collect();
            extra_at += c.extra.len();
            let p = c.effect.map_or(0, |e| e.parameter_count());
            own.extend(effect_at..effect_at + p);
            effect_at += p;
            own
        })
        .collect()
}

/// Every candidate the data can show (see the module header). `cancel` is
/// asked every [`crate::cancel::ROWS`] rows of the gravity torques; once requested,
/// the rows left are not read (the candidates are then of the rows read:
/// the caller's next check drops them).
pub fn candidates<'a>(
    robot: &Robot<f64>,
    data: impl Into<Rows<'a>>,
    cancel: Cancel,
) -> Vec<Candidate> {
    let data = data.into();
    let mut out = Vec::new();
    let both_ways = |j: usize| {
        let signs: Vec<i8> = data
            .iter()
            .filter_map(|o| o.context.approach.get(j).copied())
            .collect();
        signs.contains(&1) && signs.contains(&-1)
    };
    // The largest gravity torque each joint carries in these poses: a joint that
    // carries none (a vertical axis) cannot show a compliance.
    let mut torque = vec![0.0f64; robot.dof()];
    for (i, o) in data.iter().enumerate() {
        if cancel.requested_at(i) {
            break;
        }
        if let Ok(chain) = robot.chain(&o.q) {
            let tau = gravity_torques(robot, &chain, o.context.payload.unwrap_or(0.0));
            for (m, t) in torque.iter_mut().zip(&tau) {
                *m = m.max(t.abs());
            }
        }
    }
    let largest = torque.iter().copied().fold(0.0, f64::max);
    for (j, link) in robot.links.iter().enumerate() {
        let joint = |effect| Candidate {
            name: "",
            joints: vec![j],
            effect: Some(effect),
            extra: Vec::new(),
        };
        let mut push = |name, effect| {
            out.push(Candidate {
                name,
                ..joint(effect)
            })
        };
        if torque[j] > 1e-9 * largest {
            push(
                "joint_compliance",
                Effect::JointCompliance {
                    joint: j,
                    compliance: 0.0,
                },
            );
        }
        if link.joint == JointType::Revolute {
            push(
                "gear_transmission",
                Effect::GearTransmission {
                    joint: j,
                    first: [0.0; 2],
                    second: [0.0; 2],
                },
            );
        }
        if both_ways(j) {
            push(
                "backlash",
                Effect::Backlash {
                    joint: j,
                    half_lost_motion: 0.0,
                },
            );
        }
        push(
            "encoder_scale",
            Effect::EncoderScale {
                joint: j,
                scale: 0.0,
            },
        );
    }
    let temps: Vec<f64> = data.iter().filter_map(|o| o.context.temperature).collect();
    if temps.len() == data.len() && !temps.is_empty() {
        let (lo, hi) = temps
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(*t), b.max(*t))
            });
        if hi - lo > 1.0 {
            let reference = temps.iter().sum::<f64>() / temps.len() as f64;
            out.push(Candidate {
                name: "thermal_expansion",
                joints: Vec::new(),
                effect: Some(Effect::ThermalExpansion {
                    coefficient: 0.0,
                    reference,
                }),
                extra: Vec::new(),
            });
        }
    }
    // Nominally parallel consecutive axes: the joint axes at any configuration.
    // Hayati's tilt about y sits between the two axes: after axis `j`'s link
    // transform in standard D-H (`A_j · Rot_y(β_j)`), inside the next link's
    // in modified D-H (`Rot_x(α) Trans_x(a) · Rot_y(β) · Rot_z(θ) Trans_z(s)`
    // of link `j + 1`, whose `α`, `a` join axis `j` to axis `j + 1`).
    if let Some(chain) = data.first().and_then(|o| robot.chain(&o.q).ok()) {
        for j in 0..robot.dof().saturating_sub(1) {
            if chain.axes[j].w.cross(&chain.axes[j + 1].w).norm() < 1e-6 {
                let tilted = match robot.convention {
                    Convention::Dh => j,
                    Convention::Mdh => j + 1,
                };
                out.push(Candidate {
                    name: "parallel_axis_tilt",
                    joints: vec![j, j + 1],
                    effect: None,
                    extra: vec![Param::Beta(tilted)],
                });
            }
        }
    }
    out
}
