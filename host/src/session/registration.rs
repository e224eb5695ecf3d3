//! Several sessions in one calibration: each session's registration — where
//! the instrument saw the robot's base (the base frame, measurement frame ←
//! robot base) and where the measured point or marker sat on the flange (the
//! tool frame, flange ← tool) — beside the geometry all sessions share.
//!
//! A laser tracker moved between days, a camera re-placed, an SMR nest or a
//! marker remounted: each session is then measured in a frame of its own, and
//! with a tool of its own. The robot's geometry and its non-geometric effects
//! are the same robot's in every session; the registrations are not. So by
//! default ([`FrameSharing::default`]) every session has its own base frame
//! (6 unknowns) and its own tool (3 with positions only, 6 with
//! orientations): a frame that moved but is taken as shared would put its
//! motion into the joints' parameters, while a frame taken as a session's own
//! costs only its unknowns. Sessions measured without moving the instrument,
//! or without remounting the tool, may say so ([`Sharing::Shared`]), which
//! ties them closer.
//!
//! The first session's registration is the model's own base and tool (the
//! `Param::Base` and `Param::Tool` of the fitted robot): it is the one a
//! calibration file holds. Each later session's own frames are held here
//! ([`Registrations`]) as the same six parameters (x, y, z in m; roll, pitch,
//! yaw in rad, as [`armcal_shared::Frame`]).
//!
//! Sessions of contacts (rows at unknown fixed points or on planes) share
//! their frames: their points, named across files, are one set found in one
//! base frame.

use armcal_shared::effects::EffectModel;
use armcal_shared::{Frame, Param, Robot};

/// Whether a frame is each session's own or one for all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sharing {
    /// Each session has its own (the instrument moved, the tool remounted).
    #[default]
    PerSession,
    /// One frame for every session.
    Shared,
}

/// Which of a session's frames are its own: the base (the instrument's
/// registration) and the tool (the measured point's mount).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameSharing {
    /// The base frame: the measurement frame ← robot base.
    pub base: Sharing,
    /// The tool frame: flange ← tool.
    pub tool: Sharing,
}

impl FrameSharing {
    /// The sharing the user states: `same_base` (`--same-base`), `same_tool`
    /// (`--same-tool`); each session's own frame otherwise.
    pub fn stated(same_base: bool, same_tool: bool) -> Self {
        let sharing = |same: bool| {
            if same {
                Sharing::Shared
            } else {
                Sharing::PerSession
            }
        };
        Self {
            base: sharing(same_base),
            tool: sharing(same_tool),
        }
    }

    /// Whether `param` (a base or tool parameter) is each session's own.
    pub fn per_session(&self, param: Param) -> bool {
        match param {
            Param::Base(_) => self.base == Sharing::PerSession,
            Param::Tool(_) => self.tool == Sharing::PerSession,
            _ => false,
        }
    }
}

/// The own frames of one session after the first: `None` where it shares the
/// first session's (the model's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Registration {
    /// Its base frame.
    pub base: Option<Frame<f64>>,
    /// Its tool frame.
    pub tool: Option<Frame<f64>>,
}

/// The registrations of the sessions after the first, in order: session
/// `k ≥ 1` is `sessions[k − 1]`. Empty for one session.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Registrations {
    /// Session 2, 3, … in order.
    pub sessions: Vec<Registration>,
}

impl Registrations {
    /// The registrations of `count` sessions of `robot` sharing as `sharing`
    /// says, every own frame starting at the robot's.
    pub fn of(robot: &Robot<f64>, count: usize, sharing: FrameSharing) -> Self {
        let own = |s: Sharing, f: &Frame<f64>| (s == Sharing::PerSession).then_some(*f);
        Self {
            sessions: (1..count)
                .map(|_| Registration {
                    base: own(sharing.base, &robot.base),
                    tool: own(sharing.tool, &robot.tool),
                })
                .collect(),
        }
    }

    /// The number of sessions: the first and those held here.
    pub fn count(&self) -> usize {
        self.sessions.len() + 1
    }

    /// The robot as session `session` sees it: `robot` with that session's
    /// own frames (session 0, or a session beyond those held: `robot`).
    pub fn robot(&self, robot: &Robot<f64>, session: usize) -> Robot<f64> {
        let mut r = robot.clone();
        if let Some(reg) = session.checked_sub(1).and_then(|k| self.sessions.get(k)) {
            if let Some(b) = reg.base {
                r.base = b;
            }
            if let Some(t) = reg.tool {
                r.tool = t;
            }
        }
        r
    }

    /// `model` (a robot with its effects) as every session sees it, in order.
    pub fn effect_models(&self, model: &EffectModel<f64>) -> Vec<EffectModel<f64>> {
        self.robots(&model.robot)
            .into_iter()
            .map(|robot| EffectModel {
                robot,
                effects: model.effects.clone(),
            })
            .collect()
    }

    /// The robot of every session, in order.
    pub fn robots(&self, robot: &Robot<f64>) -> Vec<Robot<f64>> {
        (0..self.count()).map(|k| self.robot(robot, k)).collect()
    }

    /// The frame `param` (base or tool) of session `session ≥ 1`, if it is its own.
    fn frame(&self, session: usize, param: Param) -> Option<&Frame<f64>> {
        let reg = self.sessions.get(session.checked_sub(1)?)?;
        match param {
            Param::Base(_) => reg.base.as_ref(),
            Param::Tool(_) => reg.tool.as_ref(),
            _ => None,
        }
    }

    /// The value of `param` (a base or tool parameter) of session `session ≥
    /// 1`'s own frame, SI.
    pub fn param(&self, session: usize, param: Param) -> Option<f64> {
        let frame = self.frame(session, param)?;
        let (angle, i) = slot(param)?;
        Some(if angle { frame.rpy[i] } else { frame.xyz[i] })
    }

    /// A mutable reference to `param` of session `session ≥ 1`'s own frame.
    pub fn param_mut(&mut self, session: usize, param: Param) -> Option<&mut f64> {
        let (angle, i) = slot(param)?;
        let reg = self.sessions.get_mut(session.checked_sub(1)?)?;
        let frame = match param {
            Param::Base(_) => reg.base.as_mut()?,
            _ => reg.tool.as_mut()?,
        };
        Some(if angle {
            &mut frame.rpy[i]
        } else {
            &mut frame.xyz[i]
        })
    }

    /// Whether session `session` has its own base frame, its own tool
    /// (session 0, whose frames are the model's, neither here).
    pub fn own_frames(&self, session: usize) -> (bool, bool) {
        session
            .checked_sub(1)
            .and_then(|k| self.sessions.get(k))
            .map_or((false, false), |r| (r.base.is_some(), r.tool.is_some()))
    }
}

/// What session `session` sees of `per_session` (one item a session, the
/// first the model's): its own, or the first's for a session beyond them
/// (sessions that share every frame are held as one).
pub fn in_session<T>(per_session: &[T], session: usize) -> &T {
    &per_session[session.min(per_session.len() - 1)]
}

/// Where a base or tool parameter lives in its [`Frame`]: `(true, i)` is
/// `rpy[i]`, `(false, i)` is `xyz[i]`.
fn slot(param: Param) -> Option<(bool, usize)> {
    match param {
        Param::Base(a) | Param::Tool(a) => Some((a.is_angle(), a.index() % 3)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each session sees the robot through its own frames and shares the
    /// rest: the joints are the model's in every session, the first session's
    /// frames are the model's, a shared frame is the model's in all.
    #[test]
    fn each_session_sees_its_own_frames_and_the_shared_geometry() {
        use armcal_shared::{Convention, FrameAxis, JointType, Link};
        let link = |a: f64| Link::new(JointType::Revolute, 0.0, 0.1, a, 0.3);
        let robot = Robot::new(Convention::Dh, &[link(0.2), link(0.4)]).unwrap();
        let sharing = FrameSharing {
            base: Sharing::PerSession,
            tool: Sharing::Shared,
        };
        let mut regs = Registrations::of(&robot, 3, sharing);
        assert_eq!(regs.count(), 3);
        *regs.param_mut(2, Param::Base(FrameAxis::Y)).unwrap() = 0.5;
        assert!(regs.param_mut(2, Param::Tool(FrameAxis::Y)).is_none());
        assert!(regs.param_mut(0, Param::Base(FrameAxis::Y)).is_none());
        assert_eq!(regs.own_frames(1), (true, false));
        assert_eq!(regs.own_frames(0), (false, false));
        let robots = regs.robots(&robot);
        assert_eq!(robots[0], robot);
        assert_eq!(robots[1], robot);
        assert_eq!(robots[2].base.xyz.y, 0.5);
        assert_eq!(robots[2].links, robot.links);
        assert_eq!(robots[2].tool, robot.tool);
        assert_eq!(regs.param(2, Param::Base(FrameAxis::Y)), Some(0.5));
    }
}
