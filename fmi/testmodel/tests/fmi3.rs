//! The FMI 3.0 export of the oscillator end to end: packaged, imported by the same importer as
//! its FMI 2.0 twin (the same numbers, bit for bit, states and derivatives included), the
//! importer's FMI 3.0 rules, and the C functions called directly with what an importer must not
//! pass.

use std::ffi::{CStr, CString, c_char, c_void};
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

use fmi::fmi3::ffi::*;
use fmi::fmi3::layout::TIME_VR;
use fmi::import::{Error, Fmu, Instance};
use fmi_testmodel::{Oscillator, vr};

mod common;

/// The FMI 3.0 archive, packaged once per test binary.
fn archive3() -> &'static PathBuf {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("fmi3-testmodel-{}", std::process::id()));
        fmi::package::package_model3::<Oscillator>(&dir, &common::library()).unwrap()
    })
}

fn names(f: &Fmu) -> Vec<String> {
    f.description().variables.iter().map(|v| v.name.clone()).collect()
}

/// 60 steps from `t0` under a force; the outputs' bits after each, and their derivatives with
/// respect to the force at the end.
fn drive(i: &mut Instance, f: &Fmu, t0: f64) -> (Vec<u64>, Vec<f64>) {
    let (force, outs) = (f.value_reference("F").unwrap(), ["x", "v", "a"].map(|n| f.value_reference(n).unwrap()));
    let mut bits = Vec::new();
    for k in 0..60 {
        let t = t0 + k as f64 * 0.01;
        i.set_real(&[force], &[3.0 * (2.0 * t).sin()]).unwrap();
        i.do_step(t, 0.01).unwrap();
        let mut y = [0.0; 3];
        i.get_real(&outs, &mut y).unwrap();
        bits.extend(y.map(f64::to_bits));
    }
    let mut d = [0.0; 3];
    i.directional_derivative(&outs, &[force], &[1.0], &mut d).unwrap();
    (bits, d.to_vec())
}

#[test]
fn the_fmi3_twin_runs_bit_for_bit_like_the_fmi2_fmu() {
    let (two, three) = (common::fmu(), Fmu::load(archive3()).unwrap());
    assert_eq!((two.fmi_major_version(), three.fmi_major_version()), (2, 3));
    assert!(three.root().join("binaries/x86_64-linux/oscillator.so").is_file());
    let mut expected = names(&two);
    expected.insert(0, "time".into());
    assert_eq!(names(&three), expected, "the scalar view: the FMI 2.0 names, and the independent variable");
    let mut a = common::ready(&two, "two");
    let mut b = common::ready(&three, "three");
    let (ya, da) = drive(&mut a, &two, 0.0);
    let (yb, db) = drive(&mut b, &three, 0.0);
    assert_eq!(ya, yb);
    assert_eq!(da, db, "fmi3GetDirectionalDerivative means what fmi2GetDirectionalDerivative means");
    let mut steps = [0];
    b.get_integer(&[three.value_reference("steps").unwrap()], &mut steps).unwrap();
    assert_eq!(steps[0], 60);
    let mut t = [0.0];
    b.get_real(&[three.value_reference("time").unwrap()], &mut t).unwrap();
    assert_eq!(t[0], 0.6, "time: the instance's time");
}

#[test]
fn states_roll_back_and_travel_between_instances() {
    let f = Fmu::load(archive3()).unwrap();
    let mut a = common::ready(&f, "a");
    drive(&mut a, &f, 0.0);
    let s = a.get_state().unwrap();
    let first = drive(&mut a, &f, 0.6).0;
    a.set_state(&s).unwrap();
    assert_eq!(drive(&mut a, &f, 0.6).0, first, "rollback");
    let bytes = a.serialize_state(&s).unwrap();
    let mut b = f.instantiate("b", false).unwrap();
    let copy = b.deserialize_state(&bytes).unwrap();
    b.set_state(&copy).unwrap();
    assert_eq!(drive(&mut b, &f, 0.6).0, first, "the state in another instance");
    assert!(b.deserialize_state(&bytes[..bytes.len() - 1]).is_err(), "a truncated state is refused");
}

#[test]
fn the_importer_keeps_fmi3s_rule_of_no_get_after_a_set() {
    let f = Fmu::load(archive3()).unwrap();
    let mut i = common::ready(&f, "rule");
    let (force, x) = (f.value_reference("F").unwrap(), f.value_reference("x").unwrap());
    i.set_real(&[force], &[1.0]).unwrap();
    let e = i.get_real(&[x], &mut [0.0]).unwrap_err();
    assert!(matches!(&e, Error::Usage(m) if m.contains("without fmi3DoStep in between")), "{e}");
    i.do_step(0.0, 0.01).unwrap();
    i.get_real(&[x], &mut [0.0]).unwrap();
    assert!(i.set_real_input_derivatives(&[force], &[1], &[0.5]).is_err(), "FMI 3.0 has no input derivatives");
}

static LOG: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// The importer's logger of the raw calls: keeps the messages.
unsafe extern "C" fn keep(_env: *mut c_void, _status: fmi3Status, _category: *const c_char, message: *const c_char) {
    // SAFETY: the FMU passes a NUL-terminated message (FMI 3.0).
    let text = unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned();
    LOG.lock().unwrap().push(text);
}

fn last_message() -> String {
    LOG.lock().unwrap().last().cloned().unwrap_or_default()
}

/// The binary's functions called as an importer would, and as one must not.
#[test]
fn the_c_functions_refuse_what_fmi3_does_not_allow() {
    let f = Fmu::load(archive3()).unwrap();
    let lib_path = f.root().join("binaries/x86_64-linux/oscillator.so");
    // SAFETY: the FMU's own binary; each symbol below has the FMI 3.0 signature it is read as.
    unsafe {
        let lib = libloading::Library::new(&lib_path).unwrap();
        let instantiate = *lib.get::<fmi3InstantiateCoSimulationTYPE>(b"fmi3InstantiateCoSimulation").unwrap();
        let me = *lib.get::<fmi3InstantiateModelExchangeTYPE>(b"fmi3InstantiateModelExchange").unwrap();
        let enter = *lib.get::<fmi3EnterInitializationModeTYPE>(b"fmi3EnterInitializationMode").unwrap();
        let exit = *lib.get::<fmi3InstanceOnlyTYPE>(b"fmi3ExitInitializationMode").unwrap();
        let get = *lib.get::<fmi3GetTYPE<f64>>(b"fmi3GetFloat64").unwrap();
        let set = *lib.get::<fmi3SetTYPE<f64>>(b"fmi3SetFloat64").unwrap();
        let event = *lib.get::<fmi3InstanceOnlyTYPE>(b"fmi3EnterEventMode").unwrap();
        let free = *lib.get::<fmi3FreeInstanceTYPE>(b"fmi3FreeInstance").unwrap();
        let token = CString::new(f.description().guid.as_str()).unwrap();
        let resources = CString::new(format!("{}/", f.root().join("resources").display())).unwrap();
        let null = std::ptr::null_mut();

        let c = c"m";
        // instance `m` of these resources, logging to `keep`: of the token, eventModeUsed and
        // earlyReturnAllowed given
        let instantiate = |token: &CStr, event_mode_used, early_return_allowed| {
            instantiate(
                c.as_ptr(),
                token.as_ptr(),
                resources.as_ptr(),
                0,
                0,
                event_mode_used,
                early_return_allowed,
                std::ptr::null(),
                0,
                null,
                Some(keep),
                None,
            )
        };
        assert!(me(c.as_ptr(), token.as_ptr(), resources.as_ptr(), 0, 0, null, Some(keep)).is_null());
        assert!(last_message().contains("Co-Simulation only"), "{}", last_message());
        let wrong = c"{not-this-one}";
        let inst = instantiate(wrong, 0, 0);
        assert!(inst.is_null() && last_message().contains("instantiationToken `{not-this-one}`"), "{}", last_message());
        let inst = instantiate(&token, 1, 0);
        assert!(inst.is_null() && last_message().contains("eventModeUsed"), "{}", last_message());

        let fresh = || {
            let i = instantiate(&token, 0, 1);
            assert!(!i.is_null());
            assert_eq!(enter(i, 0, 0.0, 0.0, 0, 0.0), fmi3OK);
            assert_eq!(exit(i), fmi3OK);
            i
        };
        let i = fresh();
        let (mut out, x) = ([0.0; 2], [vr::X, TIME_VR]);
        assert_eq!(get(i, x.as_ptr(), 2, out.as_mut_ptr(), 2), fmi3OK);
        assert_eq!(out, [0.1, 0.0], "x0 and the start time");
        assert_eq!(get(i, x.as_ptr(), 2, out.as_mut_ptr(), 1), fmi3Error, "nValues must count the values");
        assert!(last_message().contains("nValues = 1"), "{}", last_message());
        free(i);
        let i = fresh();
        assert_eq!(set(i, [TIME_VR].as_ptr(), 1, [1.0].as_ptr(), 1), fmi3Error);
        assert!(last_message().contains("`time` (independent) cannot be set"), "{}", last_message());
        free(i);
        let i = fresh();
        assert_eq!(set(i, [vr::F].as_ptr(), 1, [f64::NAN].as_ptr(), 1), fmi3Error);
        assert!(last_message().contains("not a finite number"), "{}", last_message());
        free(i);
        let i = fresh();
        assert_eq!(event(i), fmi3Error);
        assert!(last_message().contains("no event mode"), "{}", last_message());
        free(i);
    }
}
