//! Speed of `armcal diagnose` excluding file reading: 120 tracker positions of a
//! PUMA 560 and of a UR10e (σ = 20 µm, ±1 mm / ±1 mrad geometric errors, 20–30 °C,
//! payloads 0 and 5 kg, so that every candidate of the library is tried: per
//! joint compliance, gear transmission, backlash and encoder scale, thermal
//! expansion and the parallel-axis tilts), with a hidden joint compliance of
//! joint 2 and with pure geometry; 10-fold cross-validation.
//!
//! Run: `cargo bench -p armcal --bench diagnose`.

use armcal::calibration::diagnose::{DiagnoseOptions, diagnose};
use armcal::calibration::fit::FullOptions;
use armcal::calibration::simulate::{Scenario, simulate};
use armcal::io::model_file::load_model;
use armcal_shared::effects::Effect;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("diagnose_120_poses");
    group.sample_size(20);
    let options = DiagnoseOptions {
        fit: FullOptions {
            position_noise: 20e-6,
            ..FullOptions::default()
        },
        ..DiagnoseOptions::default()
    };
    for robot in ["puma560", "ur10e"] {
        let nominal = load_model(robot).expect("built-in").robot;
        for (label, effects) in [
            ("geometry", Vec::new()),
            (
                "compliance",
                vec![Effect::JointCompliance {
                    joint: 1,
                    compliance: 2e-6,
                }],
            ),
        ] {
            let scenario = Scenario {
                effects,
                ..Scenario::tracker(120, 7)
            };
            let session = simulate(&nominal, &scenario).expect("simulates");
            group.bench_with_input(
                BenchmarkId::new(robot, label),
                &session.observations,
                |b, data| b.iter(|| diagnose(&nominal, data, &options).expect("diagnoses")),
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
