//! Natural frequencies against closed-form references.

mod common;

use cable_fmu::modes::modes;
use cable_fmu::system::{Support, System};
use common::{equilibrium, scene};

#[test]
fn lt50m_frequencies() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let (net, eq) = equilibrium(&s);
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let t = std::time::Instant::now();
        let md = modes(&sys, &sys.config_from(&eq), 10).unwrap();
        eprintln!(
            "{name}: {:?} Hz, asym {:.1e}, {:?}",
            md.frequencies_hz.iter().map(|f| format!("{f:.4}")).collect::<Vec<_>>(),
            md.stiffness_asymmetry,
            t.elapsed()
        );
    }
}
