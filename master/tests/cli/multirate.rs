//! Multi-rate systems (a unit stepping at a multiple of the macro step, its outputs held in
//! between): a step undone between two of a slow unit's steps, or at one of them, restores every
//! unit bit for bit, and the run with the undone steps taken again is the run without them.
//! The sampled system's answers per scheme: tests/python/test_zoo_systems.py.

use studies::cosim::{Coupled, FmuSystem, JacobianUpdate, Options, Scheme};

use crate::common;

const ITERATING: [(Scheme, JacobianUpdate); 4] = [
    (Scheme::Ijcsa, JacobianUpdate::EveryStep),
    (Scheme::Ijcsa, JacobianUpdate::Reuse),
    (Scheme::IqnIls, JacobianUpdate::EveryStep),
    (Scheme::Iterative, JacobianUpdate::EveryStep),
];

fn sampled(o: Options, version: u8) -> Coupled<FmuSystem> {
    let spec = common::me_system("sampled", version);
    let system = FmuSystem::load(&spec, &studies::system::needs(&o, false)).unwrap();
    let mut c = Coupled::new(system, o).unwrap();
    c.set_periods(&[1, 4]).unwrap();
    assert!(c.is_multi_rate());
    c
}

/// Every base step of the first 12 (three of the sampler's periods) undone once and taken
/// again: the units' serialized states and the outputs are the bytes they were before it, the
/// step again gives the bits of the first try, and the run ends where a run without undoing
/// ends. Base steps 4, 8 and 12 end a sampler's step; the others lie between two of them.
#[test]
fn a_step_undone_between_a_slow_units_steps_gives_the_same_bits() {
    let h = 0.025;
    for version in [2, 3] {
        for (scheme, jacobian) in ITERATING {
            let label = format!("FMI {version}, {} ({jacobian:?})", scheme.name());
            let o = Options { scheme, jacobian, tol: 1e-13, max_iter: 200, ..Options::default() };
            let mut c = sampled(o, version);
            let mut sampler_moved = 0;
            for n in 1..=12 {
                let (before, y) = (c.units_mut().serialized_states().unwrap(), c.outputs().to_vec());
                c.step(h).unwrap();
                let (first, after) = (c.outputs().to_vec(), c.units_mut().serialized_states().unwrap());
                // the sampler's state moves only at its own steps
                if after[1] != before[1] {
                    sampler_moved += 1;
                    assert_eq!(n % 4, 0, "{label}: the sampler stepped in base step {n}");
                }
                c.undo_step().unwrap();
                assert_eq!(c.units_mut().serialized_states().unwrap(), before, "{label}, base step {n}");
                assert_eq!(c.outputs(), &y[..], "{label}, base step {n}");
                c.step(h).unwrap();
                assert_eq!(c.outputs(), &first[..], "{label}: base step {n} again");
                assert_eq!(c.units_mut().serialized_states().unwrap(), after, "{label}: base step {n} again");
            }
            assert_eq!(sampler_moved, 3, "{label}");
            let mut direct = sampled(o, version);
            for _ in 1..=12 {
                direct.step(h).unwrap();
            }
            assert_eq!(direct.outputs(), c.outputs(), "{label}");
            assert_eq!(direct.units_mut().serialized_states().unwrap(), c.units_mut().serialized_states().unwrap());
        }
    }
}

/// Periods set after the first step, of the wrong count or zero are refused by the library.
#[test]
fn periods_are_checked() {
    let o = Options::default();
    let spec = common::me_system("sampled", 2);
    let load = || Coupled::new(FmuSystem::load(&spec, &studies::system::needs(&o, false)).unwrap(), o).unwrap();
    let e = load().set_periods(&[1]).unwrap_err().to_string();
    assert!(e.contains("1 periods for 2 units"), "{e}");
    let e = load().set_periods(&[1, 0]).unwrap_err().to_string();
    assert!(e.contains("0 base steps"), "{e}");
    let mut c = load();
    c.step(0.025).unwrap();
    let e = c.set_periods(&[1, 4]).unwrap_err().to_string();
    assert!(e.contains("before the first step"), "{e}");
}
