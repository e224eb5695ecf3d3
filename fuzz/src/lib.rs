//! The harnesses of armcal's fuzz targets (see `README.md`).
//!
//! Each `fuzz_targets/<name>.rs` calls one function here with libFuzzer's
//! input; `cargo test` in this directory runs the same functions over every
//! file of `corpus/<name>/` (the seeds and the reproducers of past findings)
//! without libFuzzer, and `cargo test -- --ignored write_seeds` rewrites the
//! seeds.
//!
//! Every harness panics (a crash for libFuzzer) when an assertion fails;
//! returning normally means the input was handled as the code promises.

use armcal_shared::compensation::Task;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::OnceLock;

use armcal::io::model_file::parse_model;
use armcal::session::model::RobotModel;
use armcal_shared::Calibration;

pub mod calibration;
pub mod device;
pub mod egm_robot;
pub mod link_frames;
pub mod measurements;
pub mod model_toml;
pub mod rsi_rob;
pub mod seeds;

/// Counts the heap allocations of each thread, so that a harness can check
/// that a piece of code never allocates (the controller has no heap). Per
/// thread: `cargo test` runs harnesses on parallel threads.
struct Counting;

thread_local! {
    // Const-initialised, without a destructor: usable inside the allocator.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    // After the thread's locals are gone (its exit), nothing is checked.
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
}

// SAFETY: forwards every call to the system allocator unchanged.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: the caller's contract is System's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Heap allocations of this thread since its start.
pub fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

/// A one-joint prismatic model in mm and degrees, with limits, a mass and
/// frames: the other end of the joint count from the built-in arms.
pub const ONE_JOINT_MODEL: &str = r#"name = "lift"
convention = "mdh"
length_unit = "mm"
angle_unit = "deg"
gravity = [0.0, 0.0, -9.81]

[[joint]]
type = "prismatic"
theta = 90.0
s = 10.0
a = 250.0
alpha = 0.0
limits = [0.0, 400.0]
mass = 3.5
com = [0.0, 0.0, 50.0]

[base]
xyz = [100.0, 0.0, 0.0]
rpy = [0.0, 0.0, 45.0]

[tool]
xyz = [0.0, 0.0, 120.0]
"#;

/// The models the measurement target reads against, chosen by the input's
/// first byte: the 6-joint PUMA (inches), the 9-joint TALOS torso and arm,
/// TIAGo (a prismatic lift and 7 revolute joints), the UR10e with its camera,
/// and [`ONE_JOINT_MODEL`].
pub fn models() -> &'static [RobotModel] {
    static MODELS: OnceLock<Vec<RobotModel>> = OnceLock::new();
    MODELS.get_or_init(|| {
        let mut models: Vec<RobotModel> = [
            "puma560",
            "figaroh-talos-left-arm",
            "figaroh-tiago-mocap",
            "figaroh-ur10e-camera",
        ]
        .iter()
        .map(|name| {
            let (text, file) = armcal::io::builtin::builtin_model(name).expect("a built-in model");
            parse_model(text, file).expect("the built-in model reads")
        })
        .collect();
        models.push(parse_model(ONE_JOINT_MODEL, "lift.toml").expect("the one-joint model reads"));
        models
    })
}

/// A calibration of built-in model `name` with small identified errors of
/// every kind of parameter, and, if `effects`, one effect of each kind:
/// what `armcal identify` / `diagnose` would write, identified on every joint
/// within 1 rad (or m) of 0, at 20–30 °C and 0–5 kg.
pub fn calibration_of(name: &str, task: Task, effects: bool) -> Calibration {
    use armcal_shared::effects::one_of_each;
    use armcal_shared::{FrameAxis, Param, ParamError};
    let (text, file) = armcal::io::builtin::builtin_model(name).expect("a built-in model");
    let model = parse_model(text, file).expect("the built-in model reads");
    let mut cal = Calibration::nominal(model.robot, task, model.units);
    for (param, error) in [
        (Param::Theta(1), 1e-3),
        (Param::A(2), -2e-3),
        (Param::Alpha(3), 5e-4),
        (Param::S(4), 1e-3),
        (Param::Base(FrameAxis::X), 2e-3),
        (Param::Tool(FrameAxis::Rz), -1e-3),
    ] {
        cal.errors.push(ParamError { param, error }).expect("room");
    }
    if effects {
        for e in one_of_each() {
            cal.effects.push(e).expect("room");
        }
    }
    let (lo, hi) = (vec![-1.0; cal.nominal.dof()], vec![1.0; cal.nominal.dof()]);
    cal.ranges = Some(armcal_shared::ranges::Ranges::of([
        (&lo[..], Some(20.0), Some(0.0)),
        (&hi[..], Some(30.0), Some(5.0)),
    ]));
    cal
}
