//! IJCSA with the FMUs' step-map extension (`feedsimGetStepMapDerivative`) against IJCSA with
//! finite differences and rollback (the same cable FMU with the extension not announced).

use crate::common;

use studies::cosim::{Options, Scheme};
use studies::simulate::{Method, simulate};

#[test]
fn ijcsa_with_the_extension_and_with_finite_differences_agree() {
    let (scene, file) = common::scene("lt50m_C.toml", "stepmap", |_| {});
    // The cable FMU again, its description without the StepMapDerivative annotation: a
    // standard importer's view, so the master must difference with rollback.
    let fmu = fmi::import::Fmu::load(&common::fmu_dir().join("cable_fmu.fmu")).unwrap();
    assert!(fmu.description().flags.provides_step_map_derivative);
    let mut description = <cable_fmu::CableFmu as fmi::export::Model>::description().unwrap();
    description.flags.provides_step_map_derivative = false;
    let plain = common::fmu_dir().join("plain").join("cable_fmu.fmu");
    let library = fmu.root().join("binaries/linux64/cable_fmu.so");
    let resources = <cable_fmu::CableFmu as fmi::export::Model>::resources();
    fmi::package::write_fmu(&plain, &description, &library, &resources).unwrap();
    assert!(!fmi::import::Fmu::load(&plain).unwrap().description().flags.provides_step_map_derivative);
    let plain_file = file.with_file_name("stepmap-plain.toml");
    let mut plain_scene = scene.to_scene();
    for f in &mut plain_scene.system.as_mut().unwrap().fmus {
        if f.name == "cable" {
            f.path = plain.display().to_string();
        }
    }
    std::fs::write(&plain_file, plain_scene.to_toml()).unwrap();
    let plain_scene = plain_scene.validated(&plain_file.display().to_string()).unwrap();

    let options = Options { scheme: Scheme::Ijcsa, ..Options::default() };
    let t_end = 5.0;
    let with = simulate(&scene, &file, Method::Cosim(options), 0.01, t_end).unwrap();
    let without = simulate(&plain_scene, &plain_file, Method::Cosim(options), 0.01, t_end).unwrap();
    let gap = with.error_against(&without).0;
    let peak = with.peak_mm();
    eprintln!(
        "extension {:.2} iterations/step, finite differences {:.2}; responses {gap:.3e} mm apart, peak {peak:.3} mm",
        with.mean_iterations(),
        without.mean_iterations()
    );
    assert!(peak > 1.0, "a response to compare: peak {peak} mm");
    assert!(gap <= 1e-6 * peak, "{gap:e} mm apart, peak {peak} mm");
    assert!(with.mean_iterations() <= 3.0, "{} iterations per step", with.mean_iterations());
}
