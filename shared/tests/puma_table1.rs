//! Forward kinematics of the PUMA of Mirman & Gupta, Table 1, at its six
//! positions, against values derived independently by
//! `tests/reference/puma_table1.py` (plain Python floats, eq. 5 written out entry
//! by entry, no code shared with this crate).
//!
//! Units: inches and radians, as in the table; no base, no tool, offsets zero.
//! Tolerance: both sides round about `k = 16 (M + 2) = 128` times in f64 on
//! numbers bounded by the sum of the lengths `L = 70.25 in`, so entries agree to
//! `k ε L ≈ 2e-12 in` (positions) and `k ε ≈ 3e-14` (rotations).

use armcal_shared::{Convention, JointType, Link, Robot};

/// Table 1: (s, alpha, a) of links 1..6, inches and radians.
const TABLE1_LINKS: [(f64, f64, f64); 6] = [
    (26.0, 1.570796, 0.0),
    (-8.0, 0.0, 17.0),
    (0.0, 1.570796, 0.0),
    (17.0, 1.570796, 0.0),
    (0.0, 1.570796, 0.0),
    (-2.25, 3.141593, 0.0),
];

/// Table 1: θ_1..θ_6 at positions 1..6.
const TABLE1_POSITIONS: [[f64; 6]; 6] = [
    [0.7854, -0.5236, -1.2618, 0.2618, -1.6981, -0.3490],
    [0.5708, -0.3491, -1.4363, 0.1745, -0.7854, -1.5360],
    [0.1745, -1.0944, -0.9199, 0.1745, -0.7854, -0.2618],
    [1.0454, -0.1230, -0.9090, 1.2323, -1.2420, -0.7897],
    [1.0000, -0.3000, -0.5656, 0.7890, -1.0000, -0.5400],
    [0.5943, -0.2340, -0.3405, 1.0900, -0.7897, -0.1000],
];

/// A_h at the six positions of Table 1: rows 0..3 of the 4x4, inches.
const TABLE1_FK: [[[f64; 4]; 3]; 6] = [
    [
        [0.8863899672606318, 0.44575241813947036, 0.12497042715183009, -6.7104175444901895],
        [0.4629389815375129, -0.8538141231497763, -0.23809439826041479, 3.7863790697251822],
        [0.0005703619082507161, 0.26889816814696504, -0.9631684431367652, 18.953174135752786],
    ],
    [
        [0.5810630638902774, -0.5029922160507858, -0.6398160254125893, -6.296745157837597],
        [-0.8016179053148473, -0.21788119864513023, -0.556719424086853, 5.135786002574119],
        [0.14062165431070542, 0.8363770763652485, -0.5298102834691297, 22.613360498149966],
    ],
    [
        [0.40714495680438934, 0.14387327668336375, -0.9019608995988375, -10.862992858742365],
        [-0.3074527817647696, -0.9082979271170164, -0.28366822624332805, 5.927804519183297],
        [-0.8600614926468088, 0.39280447534533425, -0.32557468116366167, 17.455164795354627],
    ],
    [
        [0.5234336950164132, -0.46470246435388585, 0.7141910014449148, -4.170513056736484],
        [0.005138965617799973, -0.8364500394435029, -0.5480190895829649, 4.751891656307078],
        [0.8520509127709703, 0.2905218600009096, -0.43543804485571574, 14.211775766290396],
    ],
    [
        [0.8650586619542717, -0.11708472817245057, 0.487816233644052, -3.8536131143936627],
        [0.0681437136117945, -0.9359467315781205, -0.34548538311110544, 6.318126490676743],
        [0.49702107165901815, 0.33210673295947635, -0.8016702390945445, 8.153279282680383],
    ],
    [
        [0.8555530093892213, -0.44535438279670003, 0.2639858364549471, 2.1617601445888064],
        [-0.22719542994987518, -0.7811588247421658, -0.5815265489531235, 9.406598062048175],
        [0.46520026304263734, 0.437550413382514, -0.7695052637986646, 6.055924896239932],
    ],
];

fn puma() -> Robot<f64> {
    let links: Vec<Link<f64>> = TABLE1_LINKS
        .iter()
        .map(|&(s, alpha, a)| Link::new(JointType::Revolute, 0.0, s, a, alpha))
        .collect();
    Robot::new(Convention::Dh, &links).unwrap()
}

#[test]
fn table1_forward_kinematics_matches_independent_derivation() {
    let robot = puma();
    let l: f64 = TABLE1_LINKS.iter().map(|(s, _, a)| s.abs() + a.abs()).sum();
    let k = 16.0 * (6.0 + 2.0);
    let (tol_rot, tol_pos) = (k * f64::EPSILON, k * f64::EPSILON * l);
    for (i, (q, want)) in TABLE1_POSITIONS.iter().zip(&TABLE1_FK).enumerate() {
        let t = robot.forward(q).unwrap().to_homogeneous();
        for r in 0..3 {
            for c in 0..4 {
                let tol = if c == 3 { tol_pos } else { tol_rot };
                assert!(
                    (t[(r, c)] - want[r][c]).abs() <= tol,
                    "position {}: A_h[{r}][{c}] = {} but the reference is {} (tol {tol:e})",
                    i + 1,
                    t[(r, c)],
                    want[r][c]
                );
            }
        }
    }
}

/// The measured point of the chain is the same as `forward`'s origin, and the
/// f32 model the controller runs reaches it to f32 precision (`k ε L`).
#[test]
fn table1_in_f32_agrees() {
    let robot = puma();
    let r32 = robot.cast::<f32>();
    for (q, want) in TABLE1_POSITIONS.iter().zip(&TABLE1_FK) {
        let q32: Vec<f32> = q.iter().map(|&x| x as f32).collect();
        let p = r32.chain(&q32).unwrap().point();
        for r in 0..3 {
            // Inputs rounded to f32 add 4 ε per link (angles up to π): k = 128 + 24π.
            let tol = (128.0 + 24.0 * std::f64::consts::PI) * f32::EPSILON as f64 * 70.25;
            assert!((p[r] as f64 - want[r][3]).abs() <= tol, "{} vs {}", p[r], want[r][3]);
        }
    }
}
