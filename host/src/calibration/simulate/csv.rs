//! A simulated session as the measurement CSV of `docs/file-formats.md` §2
//! (joints, x, y, z and qw…qz in the model's units; `t` s, `temp` °C,
//! `load` kg, `tau` N·m or N): from a session held in memory
//! ([`Session::to_csv`]), or written as its rows are drawn, without holding
//! them, one file per session ([`SessionWriter`], what `armcal simulate`
//! writes): the same bytes either way.

use std::fmt::Write as _;

use armcal_shared::units::Units;
use armcal_shared::{JointType, Robot};
use rand::rngs::StdRng;

use super::{Draw, Scenario, Session, random_configuration};
use crate::session::observation::Observation;

impl Session {
    /// The measurements as a measurement CSV (`docs/file-formats.md` §2) in `units`, with `t`, `temp`, `load`.
    pub fn to_csv(&self, units: &Units, description: &str) -> String {
        let columns = Columns {
            joints: self.truth.links.iter().map(|l| l.joint).collect(),
            orientation: self.observations.iter().any(|o| o.orientation.is_some()),
            torques: self.observations.iter().any(|o| o.torque.is_some()),
            units: *units,
        };
        let mut out = columns.header(description);
        for (i, obs) in self.observations.iter().enumerate() {
            columns.row(&mut out, obs, [self.t[i], self.temp[i], self.load[i]]);
        }
        out
    }

    /// The number of sessions the rows were measured in.
    pub fn sessions(&self) -> usize {
        self.frames.len().max(1)
    }
}

/// The columns of a simulated session's file.
struct Columns {
    joints: Vec<JointType>,
    orientation: bool,
    torques: bool,
    units: Units,
}

impl Columns {
    /// The comment lines (`description`, the units) and the header line.
    fn header(&self, description: &str) -> String {
        let (units, m) = (&self.units, self.joints.len());
        let mut out = String::new();
        let _ = writeln!(out, "# {description}");
        let _ = writeln!(
            out,
            "# lengths in {}, angles in {}; t in s, temp in °C, load in kg{}",
            units.length,
            units.angle,
            if self.torques {
                ", tau in N·m (N)"
            } else {
                ""
            }
        );
        let mut header: Vec<String> = (1..=m).map(|j| format!("q{j}")).collect();
        header.extend(["x", "y", "z"].map(String::from));
        if self.orientation {
            header.extend(["qw", "qx", "qy", "qz"].map(String::from));
        }
        header.extend(["t", "temp", "load"].map(String::from));
        if self.torques {
            header.extend((1..=m).map(|j| format!("tau{j}")));
        }
        let _ = writeln!(out, "{}", header.join(","));
        out
    }

    /// Appends the line of `obs`, measured at `[t, temp, load]`, to `out`.
    fn row(&self, out: &mut String, obs: &Observation, [t, temp, load]: [f64; 3]) {
        let units = &self.units;
        let mut row: Vec<String> = obs
            .q
            .iter()
            .zip(&self.joints)
            .map(|(q, j)| format!("{}", units.joint_from_si(*j, *q)))
            .collect();
        row.extend(
            obs.position
                .coords
                .iter()
                .map(|x| format!("{}", units.length_from_si(*x))),
        );
        if let Some(q) = obs.orientation {
            let q = if q.w < 0.0 {
                -q.into_inner()
            } else {
                q.into_inner()
            };
            row.extend([q.w, q.i, q.j, q.k].map(|v| format!("{v}")));
        }
        row.extend([t, temp, load].map(|v| format!("{v}")));
        if self.torques {
            let none = vec![0.0; self.joints.len()];
            row.extend(
                obs.torque
                    .as_ref()
                    .unwrap_or(&none)
                    .iter()
                    .map(|v| format!("{v}")),
            );
        }
        let _ = writeln!(out, "{}", row.join(","));
    }
}

/// The session [`super::simulate`] draws, written session by session as its
/// rows are drawn: memory independent of its length. The bytes are
/// [`Session::to_csv`]'s, its rows shared among the sessions' files.
pub struct SessionWriter {
    draw: Draw,
    nominal: Robot<f64>,
    /// The generator the configurations are drawn from: [`super::simulate`]
    /// draws them all before the rows' noise, so they come from a second
    /// generator in the same state, and the rows' draws from the first
    /// moved past them.
    configurations: StdRng,
    columns: Columns,
}

impl SessionWriter {
    /// The session `scenario` draws on `nominal`, to be written in `units`.
    pub fn new(
        nominal: &Robot<f64>,
        scenario: &Scenario,
        units: Units,
    ) -> Result<Self, armcal_shared::effects::EffectError> {
        let mut draw = Draw::new(nominal, scenario)?;
        // A second draw of the same truth leaves its generator where the
        // configurations begin.
        let configurations = Draw::new(nominal, scenario)?.rng;
        for _ in 0..scenario.poses {
            random_configuration(nominal, &mut draw.rng);
        }
        let columns = Columns {
            joints: nominal.links.iter().map(|l| l.joint).collect(),
            orientation: scenario.orientation_noise.is_some(),
            torques: scenario.torque_noise.is_some(),
            units,
        };
        Ok(Self {
            draw,
            nominal: nominal.clone(),
            configurations,
            columns,
        })
    }

    /// The session's truth, effects and frames, without its rows (what
    /// [`Session::truth`] reads).
    pub fn truth(&self) -> Session {
        self.draw.session()
    }

    /// Writes session `k` (from 0) into `out`: its comment and header lines,
    /// with `description`, then its rows as they are drawn. The sessions are
    /// written in order, each once.
    pub fn write_session(
        &mut self,
        k: usize,
        description: &str,
        out: &mut dyn std::io::Write,
    ) -> std::io::Result<()> {
        if self.draw.next != self.draw.first_row(k) {
            return Err(std::io::Error::other(format!(
                "internal error: simulated session {} written out of order",
                k + 1
            )));
        }
        out.write_all(self.columns.header(description).as_bytes())?;
        let mut line = String::new();
        while self.draw.next < self.draw.first_row(k + 1) {
            let q = random_configuration(&self.nominal, &mut self.configurations);
            let row = self.draw.row(&q).map_err(std::io::Error::other)?;
            line.clear();
            self.columns
                .row(&mut line, &row.observation, [row.t, row.temp, row.load]);
            out.write_all(line.as_bytes())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::simulate::{parse_effect, simulate};
    use crate::io::model_file::load_model;

    /// What `armcal simulate` writes as the rows are drawn is, byte for
    /// byte, the session [`simulate`] holds in memory written out: one
    /// session, and three (rows shared in blocks, orientations, torques, an
    /// effect and a tilt), each file with the comment and header lines and
    /// its own session's rows, in order; in inches for the PUMA.
    #[test]
    fn rows_written_as_drawn_are_the_session_held() {
        for (name, poses, sessions) in [("puma560", 41, 1), ("ur10e", 31, 3)] {
            let model = load_model(name).unwrap();
            let mut scenario = Scenario::tracker(poses, 7);
            scenario.sessions = sessions;
            if sessions > 1 {
                scenario.orientation_noise = Some(1e-4);
                scenario.torque_noise = Some(0.5);
                scenario.effects = vec![parse_effect("joint_compliance", 6).unwrap()];
                scenario.tilts = vec![(1, 1e-3)];
            }
            let held = simulate(&model.robot, &scenario).unwrap();
            let expected = held.to_csv(&model.units, "d");
            let header: String = expected.split_inclusive('\n').take(3).collect();
            let mut writer = SessionWriter::new(&model.robot, &scenario, model.units).unwrap();
            let mut rows = String::new();
            for k in 0..sessions {
                let mut written = Vec::new();
                writer.write_session(k, "d", &mut written).unwrap();
                let written = String::from_utf8(written).unwrap();
                let own = written.strip_prefix(&header).expect("the header lines");
                let count = held.observations.iter().filter(|o| o.session == k).count();
                assert_eq!(own.lines().count(), count, "{name}: session {k}'s rows");
                rows.push_str(own);
            }
            assert_eq!(header + &rows, expected, "{name}");
            let e = writer.write_session(0, "d", &mut Vec::new()).unwrap_err();
            assert!(e.to_string().contains("out of order"), "{e}");
        }
    }
}
