//! Speed of `identify --params full` on a 6-axis arm (the UR10e), excluding file
//! reading: N = 100, 1,000 and 10,000 poses, positions only (a laser tracker,
//! σ = 50 µm) and full poses (σ = 50 µm, 50 µrad). The true robot carries random
//! errors of ±1 mm and ±1 mrad on every separable parameter.
//!
//! Run: `cargo bench -p armcal --bench identify` (single-threaded: faer is built
//! without rayon).

use armcal::calibration::fit::{FitRequest, FullOptions};
use armcal::calibration::simulate::{measure, random_configurations, rng, with_random_errors};
use armcal::io::model_file::load_model;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

fn full(c: &mut Criterion) {
    let nominal = load_model("ur10e").expect("built-in").robot;
    let mut group = c.benchmark_group("identify_full");
    group.sample_size(10);
    for orientation in [false, true] {
        for n in [100usize, 1_000, 10_000] {
            let mut r = rng(n as u64);
            let params: Vec<_> = nominal.params().collect();
            let (truth, _) = with_random_errors(&nominal, &params, 1e-3, 1e-3, &mut r);
            let configs = random_configurations(&nominal, n, &mut r);
            let data = measure(
                &truth,
                &configs,
                50e-6,
                orientation.then_some(50e-6),
                &mut r,
            );
            let options = FullOptions {
                position_noise: 50e-6,
                orientation_noise: 50e-6,
                ..FullOptions::default()
            };
            let label = if orientation {
                "full_poses"
            } else {
                "positions"
            };
            group.bench_with_input(BenchmarkId::new(label, n), &data, |b, data| {
                b.iter(|| {
                    FitRequest::new(&nominal, data, &options)
                        .run()
                        .expect("converges")
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, full);
criterion_main!(benches);
