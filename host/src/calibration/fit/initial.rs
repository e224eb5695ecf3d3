//! The initial estimate: base and tool in closed form (rigid registration,
//! the chordal mean of rotations, linear least squares), and the points and
//! tool of a session without a tracker. See the parent module's "Initial
//! estimate".

use armcal_shared::{Robot, rotation_error};
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Vector3};

use super::{Model, PlaneEstimate, Registrations};
use crate::session::rows::Rows;

/// The most poses the closed-form estimate of base and tool reads: evenly
/// spaced over a longer session. A start for the fit, which then reads every
/// pose; at this many its own scatter is below a hundredth of the noise.
pub(super) const START_POSES: usize = 10_000;

/// The own frames of every session after the first of `data` (those
/// `shape` gives it), each estimated in closed form for `robot` on the
/// session's rows; the first session's, the model's own, are `robot`'s and
/// not estimated.
pub fn session_registrations<'a>(
    robot: &Robot<f64>,
    data: impl Into<Rows<'a>>,
    shape: &Registrations,
) -> Registrations {
    let data = data.into();
    let mut out = shape.clone();
    for (k, own) in out.sessions.iter_mut().enumerate() {
        let rows = data.positions_of((0..data.len()).filter(|&i| data[i].session == k + 1));
        let mut seen = robot.clone();
        initial_base_tool(&mut seen, Rows::picked(data.all(), &rows));
        if let Some(base) = own.base.as_mut() {
            *base = seen.base;
        }
        if let Some(tool) = own.tool.as_mut() {
            *tool = seen.tool;
        }
    }
    out
}

/// The closed-form estimate of base and tool with the nominal joints (see the
/// module header), from at most [`START_POSES`] of the poses.
pub(super) fn initial_base_tool(robot: &mut Robot<f64>, data: Rows<'_>) {
    let step = data.len().div_ceil(START_POSES).max(1);
    let sample: Vec<usize>;
    let data = if step > 1 {
        sample = data.positions_of((0..data.len()).step_by(step));
        Rows::picked(data.all(), &sample)
    } else {
        data
    };
    let mut bare = robot.clone();
    bare.base = armcal_shared::Frame::identity();
    bare.tool = armcal_shared::Frame::identity();
    let bare = bare.prepare();
    let flange: Vec<IsometryMatrix3<f64>> = data
        .iter()
        .filter_map(|o| bare.forward(&o.q).ok())
        .collect();
    if flange.len() != data.len() || data.len() < 3 {
        return;
    }
    let with_orientation: Vec<usize> = (0..data.len())
        .filter(|&i| data[i].orientation.is_some())
        .collect();
    let mut base = robot.base.isometry();
    let mut tool = robot.tool.isometry();
    // Sums of squares from the flange frames already computed: base · flange · tool.
    let frames_cost = |b: &IsometryMatrix3<f64>, t: &IsometryMatrix3<f64>| -> f64 {
        data.iter()
            .zip(&flange)
            .map(|(obs, f)| {
                let m = b * f * t;
                let dp = (obs.position.coords - m.translation.vector).norm_squared();
                dp + obs.orientation.map_or(0.0, |q| {
                    rotation_error(&q.to_rotation_matrix(), &m.rotation).norm_squared()
                })
            })
            .sum()
    };
    let before = frames_cost(&base, &tool);
    for _ in 0..20 {
        if with_orientation.len() >= 2 {
            // Rotations: R_meas = R_b R_f R_t, alternating chordal means.
            let rb: Matrix3<f64> = with_orientation
                .iter()
                .map(|&i| {
                    let rm = data[i].orientation.unwrap_or_default().to_rotation_matrix();
                    (rm * (flange[i].rotation * tool.rotation).inverse()).into_inner()
                })
                .sum();
            base.rotation = project_to_rotation(&rb);
            let rt: Matrix3<f64> = with_orientation
                .iter()
                .map(|&i| {
                    let rm = data[i].orientation.unwrap_or_default().to_rotation_matrix();
                    ((base.rotation * flange[i].rotation).inverse() * rm).into_inner()
                })
                .sum();
            tool.rotation = project_to_rotation(&rt);
        } else {
            // Positions only: register the current model's points onto the measured ones.
            let model: Vec<Point3<f64>> = flange
                .iter()
                .map(|f| base * (f * Point3::from(tool.translation.vector)))
                .collect();
            let measured: Vec<Point3<f64>> = data.iter().map(|o| o.position).collect();
            let correction = kabsch(&model, &measured);
            base = correction * base;
        }
        // Positions: P = t_b + R_b (p_f + R_f t_t), linear in (t_b, t_t): the 6 × 6
        // normal equations, accumulated pose by pose.
        let mut ata = nalgebra::Matrix6::<f64>::zeros();
        let mut atb = nalgebra::Vector6::<f64>::zeros();
        for (obs, f) in data.iter().zip(&flange) {
            let rbrf = base.rotation.matrix() * f.rotation.matrix();
            let mut a = nalgebra::Matrix3x6::<f64>::zeros();
            a.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            a.fixed_view_mut::<3, 3>(0, 3).copy_from(&rbrf);
            let rhs = obs.position.coords - base.rotation * f.translation.vector;
            ata += a.transpose() * a;
            atb += a.transpose() * rhs;
        }
        // Singular when the tool point cannot be told from the base (all poses alike).
        let Some(x) = ata.cholesky().map(|c| c.solve(&atb)) else {
            return;
        };
        let (tb, tt) = (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        );
        let change = (tb - base.translation.vector).norm() + (tt - tool.translation.vector).norm();
        base.translation.vector = tb;
        tool.translation.vector = tt;
        if change < 1e-12 {
            break;
        }
    }
    let mut trial = robot.clone();
    trial.base = frame_of(&base);
    trial.tool = frame_of(&tool);
    if with_orientation.len() < 2 {
        trial.tool.rpy = robot.tool.rpy; // not observable from positions: keep nominal
    }
    if frames_cost(&trial.base.isometry(), &trial.tool.isometry()) < before {
        *robot = trial;
    }
}

/// The start of a constraint session's fit: each unknown fixed point at the
/// mean of the tool points its rows put there and, when `tool` is set, the
/// tool point that brings them closest together (a linear least-squares
/// problem once the points are eliminated: `Σ_k Σ_i |(R_i − R̄_k) t + p_i − p̄_k|²`
/// over the flange frames `(R_i, p_i)` of point `k`'s rows, with a faint pull
/// to the nominal tool point where the rows leave it undetermined). The base
/// is nominal; the distances do not enter the start.
pub(super) fn initial_points_tool(model: &mut Model, data: Rows<'_>, tool: bool) {
    let mut bare = model.robot.clone();
    bare.tool = armcal_shared::Frame::identity();
    let bare = bare.prepare();
    let flange: Vec<Option<IsometryMatrix3<f64>>> =
        data.iter().map(|o| bare.forward(&o.q).ok()).collect();
    let points = model.points.len();
    // Mean flange position and rotation of each point's rows.
    let mut sums = vec![(Vector3::zeros(), Matrix3::zeros(), 0usize); points];
    for (obs, f) in data.iter().zip(&flange) {
        if let (Some(k), Some(f)) = (obs.fixed_point(), f)
            && let Some(s) = sums.get_mut(k)
        {
            s.0 += f.translation.vector;
            s.1 += f.rotation.matrix();
            s.2 += 1;
        }
    }
    let means: Vec<(Vector3<f64>, Matrix3<f64>)> = sums
        .iter()
        .map(|(p, r, n)| {
            let n = (*n).max(1) as f64;
            (p / n, r / n)
        })
        .collect();
    let mut t = model.robot.tool.xyz;
    if tool {
        let mut a = Matrix3::<f64>::zeros();
        let mut b = Vector3::<f64>::zeros();
        for (obs, f) in data.iter().zip(&flange) {
            if let (Some(k), Some(f)) = (obs.fixed_point(), f) {
                let (p_mean, r_mean) = means[k];
                let dr = f.rotation.matrix() - r_mean;
                a += dr.transpose() * dr;
                b -= dr.transpose() * (f.translation.vector - p_mean);
            }
        }
        let ridge = 1e-6 * a.trace() / 3.0;
        let a = a + Matrix3::identity() * ridge;
        let b = b + t * ridge;
        if let Some(x) = a.cholesky().map(|c| c.solve(&b))
            && x.iter().all(|v| v.is_finite())
        {
            t = x;
        }
    }
    model.robot.tool.xyz = t;
    model.points = means.iter().map(|(p, r)| Point3::from(p + r * t)).collect();
    // Each plane through its touches' centroid, normal to their least spread.
    for (k, plane) in model.planes.iter_mut().enumerate() {
        let touches: Vec<Vector3<f64>> = data
            .iter()
            .zip(&flange)
            .filter(|(o, _)| o.on_plane() == Some(k))
            .filter_map(|(_, f)| f.as_ref().map(|f| f.translation.vector + f.rotation * t))
            .collect();
        if touches.len() < 3 {
            continue;
        }
        *plane = PlaneEstimate::least_squares(&touches).0;
    }
}

/// xyz and roll-pitch-yaw of an isometry.
pub(super) fn frame_of(iso: &IsometryMatrix3<f64>) -> armcal_shared::Frame<f64> {
    let (roll, pitch, yaw) = iso.rotation.euler_angles();
    armcal_shared::Frame {
        xyz: iso.translation.vector,
        rpy: Vector3::new(roll, pitch, yaw),
    }
}

/// The rotation nearest to `m` (Frobenius norm): `U diag(1, 1, det(UVᵀ)) Vᵀ`.
pub(super) fn project_to_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Rotation3::identity();
    };
    let mut d = Matrix3::identity();
    d[(2, 2)] = (u * vt).determinant().signum();
    Rotation3::from_matrix_unchecked(u * d * vt)
}

/// The rigid motion `T` minimising `Σ |T a_i − b_i|²` (Kabsch/Horn).
pub(super) fn kabsch(a: &[Point3<f64>], b: &[Point3<f64>]) -> IsometryMatrix3<f64> {
    let n = a.len() as f64;
    let ca = a.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let cb = b.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = a
        .iter()
        .zip(b)
        .map(|(p, q)| (q.coords - cb) * (p.coords - ca).transpose())
        .sum();
    let r = project_to_rotation(&h);
    IsometryMatrix3::from_parts((cb - r * ca).into(), r)
}
