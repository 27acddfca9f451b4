//! What the time loop allocates, counted by a global allocator: the monolithic model's steps and
//! the co-simulation's bookkeeping around the FMUs (their own allocations happen inside their
//! libraries, with their own allocator, and are not counted here).

#[path = "common/mod.rs"]
mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use studies::cosim::{Coupled, FmuSystem, JacobianUpdate, Options, Scheme};
use studies::monolithic::Monolithic;

/// Counts the allocations of the thread that makes them.
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: every call goes to the system allocator with the caller's arguments; counting touches
// only a thread-local counter, which does not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        // SAFETY: the caller's obligations are those of `System.alloc`.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` above, which is `System`'s.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        // SAFETY: as for `System.realloc`; `ptr` came from this allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn the_counter_counts() {
    assert_eq!(allocations(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);
    assert_eq!(allocations(|| drop(std::hint::black_box(String::new()))), 0);
}

#[test]
fn the_monolithic_model_steps_without_allocating() {
    let (scene, _) = common::scene("lt50m_C.toml", "allocations-monolithic", |_| {});
    let mut m = Monolithic::new(&scene).unwrap();
    for _ in 0..100 {
        m.step(0.01).unwrap();
    }
    let n = allocations(|| {
        for _ in 0..100 {
            m.step(0.01).unwrap();
        }
    });
    assert_eq!(n, 0, "allocations in 100 monolithic steps");
}

/// The LQG law too: its readings, fixes on their way and the controller's update reuse their
/// storage (a reading every 4 steps, a fix every 8).
#[test]
fn the_lqg_law_steps_without_allocating() {
    let (scene, _) = common::scene("lt50m_C_lqg.toml", "allocations-lqg", |_| {});
    let mut m = Monolithic::new(&scene).unwrap();
    for _ in 0..400 {
        m.step(0.0025).unwrap();
    }
    let n = allocations(|| {
        for _ in 0..100 {
            m.step(0.0025).unwrap();
        }
    });
    assert_eq!(n, 0, "allocations in 100 monolithic steps with the LQG law");
}

#[test]
fn the_co_simulation_steps_without_allocating() {
    let (scene, file) = common::scene("lt50m_C.toml", "allocations-cosim", |_| {});
    let spec = studies::system::scene_spec(&scene, &file).unwrap();
    schemes_step_without_allocating(&spec, "FMI 2.0");
    // the FMI 3.0 twins: the importer's plans and buffers are made once
    let mut spec3 = spec.clone();
    for c in &mut spec3.components {
        c.source = common::fmu_dir().join("fmi3").join(c.source.file_name().unwrap());
    }
    schemes_step_without_allocating(&spec3, "FMI 3.0");
}

/// Units the master integrates (Model Exchange), with a Co-Simulation FMU: the ball's steps
/// hold impacts (state events, the event iteration) and the loop's IJCSA differences through
/// the unit; the integrator's buffers are made once, at set-up. Every scheme, FMI 2.0 and 3.0.
#[test]
fn model_exchange_units_step_without_allocating() {
    for version in [2, 3] {
        for which in ["ball", "loop"] {
            let spec = common::me_system(which, version);
            let label = format!("{which}, FMI {version}");
            schemes_step_without_allocating(&spec, &label);
            if which == "ball" {
                for scheme in [Scheme::Jacobi, Scheme::GaussSeidel { reversed: false }] {
                    let options = Options { scheme, ..Options::default() };
                    let system = FmuSystem::load(&spec, &studies::system::needs(&options, false)).unwrap();
                    let mut c = Coupled::new(system, options).unwrap();
                    for _ in 0..100 {
                        c.step(0.01).unwrap();
                    }
                    let events = |c: &Coupled<FmuSystem>| c.units().model_exchange_stats()[0].2.state_events;
                    let before = events(&c);
                    let n = allocations(|| {
                        for _ in 0..100 {
                            c.step(0.01).unwrap();
                        }
                    });
                    assert_eq!(n, 0, "allocations in 100 macro steps of {} ({label})", scheme.name());
                    assert!(events(&c) - before >= 3, "impacts in the steps counted ({label})");
                }
            }
        }
    }
}

/// The fixed-step schemes over `spec`, 100 macro steps each after 100 of warm-up.
fn schemes_step_without_allocating(spec: &studies::cosim::SystemSpec, version: &str) {
    for (scheme, jacobian) in [
        (Scheme::Ijcsa, JacobianUpdate::EveryStep),
        (Scheme::Ijcsa, JacobianUpdate::Reuse),
        (Scheme::IqnIls, JacobianUpdate::EveryStep),
        (Scheme::Iterative, JacobianUpdate::EveryStep),
    ] {
        let options = Options { scheme, jacobian, ..Options::default() };
        let system = FmuSystem::load(spec, &studies::system::needs(&options, false)).unwrap();
        let mut c = Coupled::new(system, options).unwrap();
        for _ in 0..100 {
            c.step(0.01).unwrap();
        }
        let n = allocations(|| {
            for _ in 0..100 {
                c.step(0.01).unwrap();
            }
        });
        assert_eq!(n, 0, "allocations in 100 macro steps of {} ({jacobian:?}, {version})", scheme.name());
    }
}

#[test]
fn the_adaptive_macro_step_does_not_allocate() {
    let (scene, file) = common::scene("lt50m_C.toml", "allocations-adaptive", |_| {});
    let spec = studies::system::scene_spec(&scene, &file).unwrap();
    // the adaptive macro step: its estimate, controller and rollbacks
    let options = Options { scheme: Scheme::Ijcsa, ..Options::default() };
    let system = FmuSystem::load(&spec, &studies::system::needs(&options, true)).unwrap();
    let mut c = Coupled::new(system, options).unwrap();
    let adaptive = studies::system::Adaptive {
        tolerances: studies::cosim::step_control::Tolerances { rtol: 1e-4, atol: 1e-7 },
        h_min: 1e-5,
        h_max: 0.02,
        watch: Vec::new(),
        estimate: studies::cosim::error_estimate::Kind::Predictor,
    };
    let mut ctl = adaptive.controller().unwrap();
    let tol = adaptive.tolerances;
    for _ in 0..100 {
        c.step_adaptive(&mut ctl, tol, 100.0).unwrap();
    }
    let n = allocations(|| {
        for _ in 0..100 {
            c.step_adaptive(&mut ctl, tol, 100.0).unwrap();
        }
    });
    assert_eq!(n, 0, "allocations in 100 adaptive macro steps of ijcsa");
}
