//! The cost of the diagnosis' model selection, against one identification: a
//! budget of the optimised build, checked with
//! `cargo test --release -p armcal-tests --test selection_cost`.

use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
use armcal::calibration::fit::{FitRequest, FullOptions};
use armcal::calibration::simulate::{Scenario, simulate};
use armcal::io::model_file::load_model;

/// The whole selection (reference fit, blunder test, 17 geometric models, every
/// effect candidate, the refits) on 120 tracker poses of a PUMA with a hidden
/// compliance costs at most 10 times one identification of the same poses
/// (the best of fifteen timings each, interleaved; the only test of its binary,
/// so that no other test runs beside it). The fits are timed ten in a row, a
/// timing as long as the selection's: the best of short timings is the one
/// that no interrupt of the machine happened to fall in, which a timing ten
/// times longer cannot be, and the ratio would count the interrupts the
/// selection saw against it.
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "a budget of the optimised build: run it with --release --include-ignored"
)]
fn the_selection_costs_at_most_ten_fits() {
    use std::time::Instant;
    let nominal = load_model("puma560").unwrap().robot;
    let mut scenario = Scenario::tracker(120, 3);
    scenario.effects = vec![armcal_shared::effects::Effect::JointCompliance {
        joint: 1,
        compliance: 1e-5,
    }];
    let data = simulate(&nominal, &scenario).unwrap().observations;
    let best = |f: &mut dyn FnMut()| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    // Interleaved, so that a machine busy with something else slows both alike.
    let (mut fit, mut selection) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let fits = 10;
        fit = fit.min(
            best(&mut || {
                for _ in 0..fits {
                    FitRequest::new(&nominal, &data, &FullOptions::default())
                        .run()
                        .unwrap();
                }
            }) / fits as f64,
        );
        selection = selection.min(best(&mut || {
            diagnose(&nominal, &data, &DiagnoseOptions::default()).unwrap();
        }));
    }
    eprintln!(
        "one fit {:.2} ms, the selection {:.2} ms: {:.1}×",
        fit * 1e3,
        selection * 1e3,
        selection / fit
    );
    assert!(selection <= 10.0 * fit);
}
