//! The [`zoo_models`] as FMI 2.0 Co-Simulation FMUs: each adapter maps the model's parameters,
//! inputs and state to FMI variables and implements [`fmi::Model`]; a cdylib crate per FMU
//! (`testfmus/cdylib/*`) exports it. They know nothing of the LT50m system or of this
//! workspace's extension (no step-map derivative): a master meets them as any third-party FMU.
//!
//! | FMU | inputs | outputs | derivatives (FMI 2.0, at a communication point) |
//! |---|---|---|---|
//! | `dahlquist` | `u` | `x`, `der_x` | `der_x` on `u` (feedthrough) |
//! | `van_der_pol` | `u` | `x0`, `x1`, `der_x0`, `der_x1` | `der_x1` on `u` (feedthrough) |
//! | `bouncing_ball` | — | `h`, `v`, `bounces`, `resting` | — |
//! | `feedthrough` | one of each type | the inputs | the Real outputs on their inputs |
//! | `stair` | — | `counter` | — (ends with fmi2Discard at its final count) |
//! | `resource` | — | `y`, `points`, `title` from a file in `resources/` | — |
//!
//! [`hostile`] is no member of the zoo: a Model Exchange FMU that misbehaves on request, for the
//! master's tests (`master package` leaves it out).

pub mod bouncing_ball;
pub mod dahlquist;
pub mod feedthrough;
pub mod hostile;
pub mod resource;
pub mod stair;
pub mod van_der_pol;

use fmi::{CoSimulationFlags, DefaultExperiment, ModelDescription, Variable};

/// A description with this crate's conventions: model name = identifier, start 0, the given
/// stop time and step.
fn description(
    identifier: &str,
    guid: &str,
    text: &str,
    derivatives: bool,
    experiment: (f64, f64),
    variables: Vec<Variable>,
) -> ModelDescription {
    let flags = CoSimulationFlags { provides_directional_derivative: derivatives, ..CoSimulationFlags::EXPORTED };
    let mut d = ModelDescription::co_simulation(identifier, guid, text, env!("CARGO_PKG_VERSION"), flags, variables);
    d.default_experiment = Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(experiment.0),
        step_size: Some(experiment.1),
        tolerance: None,
    });
    d
}

/// `d` offering Model Exchange too, with these continuous states and event indicators.
fn with_model_exchange(mut d: ModelDescription, states: &[(u32, u32)], event_indicators: &[u32]) -> ModelDescription {
    let states = states.iter().map(|&(state, derivative)| fmi::ContinuousState { state, derivative }).collect();
    d.model_exchange = Some(fmi::ModelExchange::exported(&d.model_identifier, states, event_indicators.to_vec()));
    d
}

/// `out = J · seed`, `J` of the partial derivatives `partial(unknown, known)`.
fn from_partials(
    at: fmi::export::Seeds<'_>,
    out: &mut [f64],
    partial: impl Fn(u32, u32) -> Result<f64, fmi::export::ModelError>,
) -> Result<(), fmi::export::ModelError> {
    for (o, &unknown) in out.iter_mut().zip(at.unknowns) {
        *o = 0.0;
        for (&known, &seed) in at.knowns.iter().zip(at.seed) {
            *o += partial(unknown, known)? * seed;
        }
    }
    Ok(())
}

/// The message for a derivative with respect to a known the model does not take.
fn not_a_known(vr: u32, known: &str) -> fmi::export::ModelError {
    format!("derivatives with respect to value reference {vr} are not provided (knowns: {known})").into()
}

/// The message for an unknown the model has no derivative of.
fn not_an_unknown(vr: u32) -> fmi::export::ModelError {
    format!("no derivative of value reference {vr} (not a Real output)").into()
}

#[cfg(test)]
mod tests {
    use fmi::export::Model;

    /// Every description is valid and reads back through the importer's parser as written.
    fn reads_back<M: Model>() {
        let info = fmi::ModelInfo::new(M::description().unwrap()).unwrap();
        let text = fmi::xml::model_description_xml(&info.description).unwrap();
        // FMI 2.0 gives the number of event indicators, not which variables they are
        let mut expected = info.description.clone();
        if let Some(me) = expected.model_exchange.as_mut() {
            me.event_indicator_variables.clear();
        }
        assert_eq!(fmi::xml::parse_model_description(&text).unwrap(), expected);
        assert!(!info.description.flags.provides_step_map_derivative, "the zoo knows no extension");
    }

    #[test]
    fn every_description_is_valid_and_reads_back_equal() {
        reads_back::<crate::dahlquist::DahlquistFmu>();
        reads_back::<crate::van_der_pol::VanDerPolFmu>();
        reads_back::<crate::bouncing_ball::BouncingBallFmu>();
        reads_back::<crate::feedthrough::FeedthroughFmu>();
        reads_back::<crate::stair::StairFmu>();
        reads_back::<crate::resource::ResourceFmu>();
        reads_back::<crate::hostile::HostileFmu>();
    }
}
