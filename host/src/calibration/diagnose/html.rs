//! The page `armcal diagnose --html` writes: one self-contained HTML file with
//! inline SVG (it opens offline), showing what the geometric model gets wrong and
//! what the extension fixes.
//!
//! For each effect found, the residual of the geometric calibration and of the
//! extended one, each projected on the direction in which the effect moves the
//! tool point at that pose (m → mm), is plotted against the variable that explains
//! it: the gravity torque on the joint (compliance), the joint reading (gear
//! transmission, encoder scale), the approach direction (backlash), the
//! temperature (thermal expansion), the row (a tilt). With nothing found, the
//! residual is plotted against the row order. Then the held-out gain table, the
//! findings with their evidence, and the parameter table with standard errors.

use std::fmt::Write as _;

use armcal_shared::effects::{Effect, gravity_torques, joint_param};
use armcal_shared::jacobian::at_point;
use armcal_shared::{Param, Twist};
use nalgebra::Vector3;

use crate::calibration::diagnose::report::{DiagnoseReport, DiagnosisReport};
use crate::calibration::diagnose::{Diagnosis, residuals};
use crate::calibration::fit::noise::NoiseSource;
use crate::report::format::significant;
use crate::report::html::{html_escape, page_head};
use crate::session::model::RobotModel;
use crate::session::observation::Observation;
use crate::session::registration::in_session;

/// One scatter plot: points `(x, y)` in two series (before: the geometric
/// calibration's residuals, after: the extended one's), mm.
struct Plot {
    title: String,
    x_label: String,
    /// Whether y is a length (its axis from 0) or a signed residual along a
    /// direction.
    length: bool,
    before: Vec<(f64, f64)>,
    after: Vec<(f64, f64)>,
}

/// The plot as SVG, `w × h` px, with real axes ([`crate::report::svg`]).
fn svg(plot: &Plot, w: f64, h: f64) -> String {
    use crate::report::svg::{Point, Scatter, Series};
    let series = |name: &str, colour, points: &[(f64, f64)]| Series {
        name: name.into(),
        colour,
        radius: 2.2,
        points: points
            .iter()
            .map(|&(x, y)| Point { x, y, value: None })
            .collect(),
    };
    Scatter {
        title: plot.title.clone(),
        x_label: plot.x_label.clone(),
        y_label: if plot.length {
            "residual length [mm]".into()
        } else {
            "residual along it [mm]".into()
        },
        value_label: String::new(),
        series: vec![
            series("geometric calibration", "#d62728", &plot.before),
            series("extended calibration", "#1f77b4", &plot.after),
        ],
        equal_aspect: false,
        y_from_zero: plot.length,
    }
    .svg(w, h)
}

/// The plots of the findings (see the module header).
fn plots(model: &RobotModel, d: &Diagnosis, data: &[Observation]) -> Vec<Plot> {
    let (before, after) = (residuals(&d.geometric, data), residuals(&d.fit, data));
    let robots = d.geometric.registrations.robots(&d.geometric.calibrated);
    let mut out = Vec::new();
    for f in &d.findings {
        // The direction the effect moves the tool point at each pose, and its variable.
        let mut dirs = Vec::new();
        let mut xs = Vec::new();
        for (i, o) in data.iter().enumerate() {
            let robot = in_session(&robots, o.session);
            let Ok(chain) = robot.chain(&o.q) else {
                continue;
            };
            let p = chain.point();
            let (col, x): (Twist<f64>, f64) = match (f.candidate.effect, f.candidate.extra.first())
            {
                (Some(Effect::ThermalExpansion { .. }), _) => {
                    let col = (0..robot.dof())
                        .map(|k| {
                            chain.column(Param::A(k)) * robot.links[k].a
                                + chain.column(Param::S(k)) * robot.links[k].s
                        })
                        .fold(Twist::zeros(), |a, c| a + c);
                    (col, o.context.temperature.unwrap_or(0.0))
                }
                (Some(e), _) => {
                    let j = e.joint().unwrap_or(0);
                    let col = chain.column(joint_param(robot, j));
                    let x = match e {
                        Effect::JointCompliance { .. } => {
                            gravity_torques(robot, &chain, o.context.payload.unwrap_or(0.0))[j]
                        }
                        Effect::Backlash { .. } => {
                            f64::from(o.context.approach.get(j).copied().unwrap_or(0))
                        }
                        _ => model.units.joint_from_si(robot.links[j].joint, o.q[j]),
                    };
                    (col, x)
                }
                (None, Some(p)) => (chain.column(*p), i as f64),
                (None, None) => continue,
            };
            let v = at_point(&col, &p);
            dirs.push((i, v / v.norm().max(f64::MIN_POSITIVE)));
            xs.push(x);
        }
        let series = |r: &[Vector3<f64>]| -> Vec<(f64, f64)> {
            dirs.iter()
                .zip(&xs)
                .filter_map(|((i, d), x)| r.get(*i).map(|r| (*x, r.dot(d) * 1e3)))
                .collect()
        };
        let x_label = match f.candidate.effect {
            Some(Effect::JointCompliance { joint, .. }) => {
                format!("gravity torque on joint {} [N·m]", joint + 1)
            }
            Some(Effect::Backlash { joint, .. }) => {
                format!("approach direction of joint {} (−1, +1)", joint + 1)
            }
            Some(Effect::ThermalExpansion { .. }) => "temperature [°C]".into(),
            Some(e) => format!(
                "joint {} reading [{}]",
                e.joint().unwrap_or(0) + 1,
                model.units.angle
            ),
            None => "row (measurement order)".into(),
        };
        out.push(Plot {
            title: format!(
                "{} (joints {}): residual along the effect's direction",
                f.candidate.name,
                f.candidate.joints_label()
            ),
            x_label,
            length: false,
            before: series(&before),
            after: series(&after),
        });
    }
    let norms = |r: &[Vector3<f64>]| {
        r.iter()
            .enumerate()
            .map(|(i, v)| (i as f64, v.norm() * 1e3))
            .collect()
    };
    out.push(Plot {
        title: "residual length in measurement order".into(),
        x_label: "row (measurement order)".into(),
        length: true,
        before: norms(&before),
        after: norms(&after),
    });
    out
}

/// One pose of a joint's panels: its index, the joint's direction of motion at
/// the tool point, and the joint reading, gravity torque and approach sign.
type PanelRow = (usize, Vector3<f64>, f64, f64, f64);

/// Which variable of a [`PanelRow`] a panel plots against.
type Pick = dyn Fn(&PanelRow) -> f64;

/// The panels of every variable a calibration engineer would look at (see the
/// section's text in [`html`]).
fn panels(model: &RobotModel, d: &Diagnosis, data: &[Observation]) -> Vec<Plot> {
    let (before, after) = (residuals(&d.geometric, data), residuals(&d.fit, data));
    let robots = d.geometric.registrations.robots(&d.geometric.calibrated);
    let robot = &robots[0];
    let mut out = Vec::new();
    for j in 0..robot.dof() {
        // Direction of joint j's motion at the tool point, and the three variables.
        let mut rows = Vec::new();
        for (i, o) in data.iter().enumerate() {
            let robot = in_session(&robots, o.session);
            let Ok(chain) = robot.chain(&o.q) else {
                continue;
            };
            let v = at_point(&chain.column(joint_param(robot, j)), &chain.point());
            let dir = v / v.norm().max(f64::MIN_POSITIVE);
            let tau = gravity_torques(robot, &chain, o.context.payload.unwrap_or(0.0))[j];
            let sigma = f64::from(o.context.approach.get(j).copied().unwrap_or(0));
            rows.push((
                i,
                dir,
                model.units.joint_from_si(robot.links[j].joint, o.q[j]),
                tau,
                sigma,
            ));
        }
        let series = |r: &[Vector3<f64>], pick: &dyn Fn(&PanelRow) -> f64| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|row| r.get(row.0).map(|res| (pick(row), res.dot(&row.1) * 1e3)))
                .collect()
        };
        let unit = model.units.joint_unit(robot.links[j].joint);
        let variables: [(String, &Pick); 3] = [
            (format!("joint {} reading [{unit}]", j + 1), &|r| r.2),
            (format!("gravity torque on joint {} [N·m]", j + 1), &|r| {
                r.3
            }),
            (format!("approach direction of joint {}", j + 1), &|r| r.4),
        ];
        for (label, pick) in variables {
            out.push(Plot {
                title: format!("along joint {}'s motion", j + 1),
                x_label: label,
                length: false,
                before: series(&before, pick),
                after: series(&after, pick),
            });
        }
    }
    let norm_against =
        |label: &str, x: &dyn Fn(usize, &Observation) -> Option<f64>| -> Option<Plot> {
            let pts = |r: &[Vector3<f64>]| -> Vec<(f64, f64)> {
                data.iter()
                    .enumerate()
                    .filter_map(|(i, o)| Some((x(i, o)?, r.get(i)?.norm() * 1e3)))
                    .collect()
            };
            let (b, a) = (pts(&before), pts(&after));
            (!b.is_empty()).then(|| Plot {
                title: "residual length".into(),
                x_label: label.into(),
                length: true,
                before: b,
                after: a,
            })
        };
    // Time: the rows are in measurement order (docs/file-formats.md §2), so the row stands for it.
    out.extend(norm_against("row (measurement order: time)", &|i, _| {
        Some(i as f64)
    }));
    out.extend(norm_against("temperature [°C]", &|_, o| {
        o.context.temperature
    }));
    out.extend(norm_against("payload [kg]", &|_, o| o.context.payload));
    out
}

/// The whole page of the diagnosis `d` of `data` by `model`: its text and
/// tables rendered from its `report`, as the summary is; the plots from the
/// diagnosis and the rows, which the report does not hold. The masses' fit
/// to the measured torques, the sessions and the weights come first, as
/// the summary gives them.
pub fn html(
    report: &DiagnoseReport,
    model: &RobotModel,
    d: &Diagnosis,
    data: &[Observation],
) -> String {
    let r = &report.diagnosis;
    let mut s = String::new();
    let _ = write!(
        s,
        "{head}<p>Model <b>{name}</b>, data <b>{data_file}</b>: {n} poses.</p>",
        head = page_head("diagnose", &r.model),
        name = html_escape(&r.model),
        data_file = html_escape(&report.data),
        n = report.poses,
    );
    if let Some(g) = &report.gravity {
        s.push_str(&g.html());
    }
    if let Some(sessions) = &report.sessions {
        s.push_str(&crate::calibration::identify::sessions::html(sessions));
    }
    s.push_str(&report.weights.html());
    html_models(&mut s, r);
    html_findings(&mut s, r, model, d, data);
    html_holdout(&mut s, r);
    html_parameters(&mut s, r);
    s
}

/// The model chosen, every model's held-out error, the noises, the prior's role.
fn html_models(s: &mut String, r: &DiagnosisReport) {
    let _ = write!(
        s,
        "<h2>The model chosen on held-out poses</h2><p>Chosen: <b>{}</b>.</p><p>Each geometric model's held-out error{}:</p><table><tr><th>model</th><th>parameters</th><th>held-out RMS [mm]</th><th>mean [mm]</th><th>max [mm]</th></tr>",
        html_escape(&r.chosen.label),
        html_escape(&r.models_scored())
    );
    for m in &r.models {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td></tr>",
            html_escape(&m.model),
            m.parameters,
            m.rms_mm,
            m.mean_mm,
            m.max_mm
        );
    }
    let _ = write!(s, "</table><p>");
    html_residuals(s, r);
    let list = crate::calibration::diagnose::summary::name_list;
    let _ = write!(
        s,
        "</p><p>Moved by the data: {}. Held near nominal by the prior: {}.</p>",
        list(&r.prior_role.moved_by_data),
        list(&r.prior_role.held_by_prior)
    );
}

/// The noise of each channel, in the model's unit (and mm for a length), as
/// the terminal's summary gives it: an estimated noise is what the geometric
/// calibration's residuals show (the instrument's noise and what the geometry
/// does not model), named so, with what the extended calibration leaves
/// beside it when it extends the geometry; a stated noise is the noise.
fn html_residuals(s: &mut String, r: &DiagnosisReport) {
    let units = r.units.units();
    for n in &r.noise {
        let (what, unit) = (n.what, &n.unit);
        let (used, shown) = (significant(n.used), significant(n.shown));
        let in_mm = if *unit == units.length.name() && units.length.name() != "mm" {
            format!(" ({} mm)", significant(units.length_to_si(n.used) * 1e3))
        } else {
            String::new()
        };
        let _ = match n.source {
            NoiseSource::Stated => write!(
                s,
                "Noise of the {what}s: <b>{used} {unit}</b>{in_mm} per axis (stated); the geometric calibration's residuals show {shown} {unit}. "
            ),
            NoiseSource::Estimated => write!(
                s,
                "The geometric calibration's residuals, {what}s: <b>{used} {unit}</b>{in_mm} per axis ({} from them as the {what} noise every fit weighs the rows by: the instrument's noise and whatever the geometry does not model). ",
                n.source_name()
            ),
        };
    }
    if r.extends_the_geometry {
        let _ = write!(
            s,
            "The extended calibration's residuals, positions: <b>{} mm</b> per axis (what the calibration chosen leaves). ",
            significant(r.noise_estimate_mm)
        );
    }
}

/// What the geometric model gets wrong: the findings, the plots, the
/// residual panels.
fn html_findings(
    s: &mut String,
    r: &DiagnosisReport,
    model: &RobotModel,
    d: &Diagnosis,
    data: &[Observation],
) {
    let _ = write!(s, "<h2>What the geometric model gets wrong</h2>");
    if r.effects.is_empty() {
        let _ = write!(
            s,
            "<p><b>Nothing beyond geometry</b>: the geometric calibration explains the data to the noise.</p>"
        );
    }
    let _ = write!(s, "<ul>");
    for e in &r.effects {
        let _ = write!(s, "<li>{}", html_escape(&e.sentence()));
        for a in &e.alike {
            let _ = write!(s, "<br>{}", html_escape(&a.sentence()));
        }
        s.push_str("</li>");
    }
    let _ = write!(s, "</ul><div class=\"plots\">");
    for p in plots(model, d, data) {
        s.push_str(&svg(&p, 560.0, 300.0));
    }
    let _ = write!(
        s,
        "</div><h2>Residuals against what could explain them</h2><p>The residual of the geometric calibration (red) and of the extended one (blue) along each joint's direction of motion at the tool point, against that joint's reading, the gravity torque on it and its approach direction; the residual length against time (row order), temperature and payload.</p><div class=\"plots\">"
    );
    for p in panels(model, d, data) {
        s.push_str(&svg(&p, 380.0, 220.0));
    }
}

/// The held-out gain table, the fitted figures, blunders and repeated configurations.
fn html_holdout(s: &mut String, r: &DiagnosisReport) {
    let _ = write!(
        s,
        "</div><h2>Gain on held-out poses ({}-fold)</h2><table><tr><th>model</th><th>RMS [mm]</th><th>mean [mm]</th><th>max [mm]</th></tr>",
        r.holdout.folds
    );
    for (label, rms, mean, max) in r.holdout.rows() {
        let _ = write!(
            s,
            "<tr><td>{label}</td><td>{rms:.4}</td><td>{mean:.4}</td><td>{max:.4}</td></tr>",
        );
    }
    if let Some(f) = &r.fitted {
        let _ = write!(
            s,
            "<tr><td>fitted, in-sample: the calibration written, at the poses it was fitted to (what <code>armcal predict</code> gives with it)</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td></tr>",
            f.rms_mm, f.mean_mm, f.max_mm
        );
    }
    let _ = write!(s, "</table>");
    let set_aside = r.suspect_rows.iter().filter(|b| b.set_aside).count();
    if !r.suspect_rows.is_empty() {
        let _ = write!(
            s,
            "<p>Blunders: {} poses flagged at a robust scale, {set_aside} set aside because the other poses are predicted better held-out without them (the data lines: the summary and the JSON's <code>outlier_rows</code>).</p>",
            r.suspect_rows.len()
        );
    }
    if let Some(rep) = &r.replicates {
        let _ = write!(
            s,
            "<p>Repeated configurations: {} rows in {} distinct configurations, fitted and held out as their means.",
            rep.rows, rep.configurations
        );
        if let (Some(pure), Some(shown), Some(expected), Some(f), Some(threshold), Some(lack)) = (
            rep.pure_error_mm,
            rep.residual_at_means_mm,
            rep.expected_at_means_mm,
            rep.lack_of_fit_f,
            rep.lack_of_fit_threshold,
            rep.lack_of_fit,
        ) {
            let _ = write!(
                s,
                " The repeats show an instrument noise of {} mm per axis; the model leaves {} mm at the means where the instrument alone would leave {} mm (F = {f:.2}, 1 % threshold {threshold:.2}: {}).",
                significant(pure),
                significant(shown),
                significant(expected),
                if lack {
                    "lack of fit"
                } else {
                    "no lack of fit"
                }
            );
        }
        let _ = write!(s, "</p>");
    }
}

/// The parameters of the extended calibration, its effects, and the page's end.
fn html_parameters(s: &mut String, r: &DiagnosisReport) {
    let _ = write!(
        s,
        "<h2>Parameters of the extended calibration</h2><table><tr><th>parameter</th><th>unit</th><th>nominal</th><th>error</th><th>std</th><th>status</th></tr>"
    );
    for p in &r.parameters {
        let unit = p.unit(&r.units);
        let std = p.std.map_or("–".into(), |s| format!("{s:.3e}"));
        let status = p
            .reason
            .as_deref()
            .map_or("identified".to_string(), |why| format!("fixed: {why}"));
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{unit}</td><td>{:.6}</td><td>{:.4e}</td><td>{std}</td><td style=\"text-align:left\">{status}</td></tr>",
            p.name, p.nominal, p.error
        );
    }
    for e in &r.effect_parameters {
        let std = e.std.map_or("–".into(), |s| format!("{s:.3e}"));
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>0</td><td>{:.4e}</td><td>{std}</td><td style=\"text-align:left\">{}</td></tr>",
            e.name, e.unit, e.value, e.effect
        );
    }
    let _ = writeln!(s, "</table><p>Written by armcal.</p></body></html>");
}
