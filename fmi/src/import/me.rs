//! The Model Exchange calls of an instance, FMI 2.0 and 3.0: time, continuous states and their
//! derivatives, event indicators, and the modes of the event iteration.

use super::{Binary, Error, Instance, Interface};
use crate::ffi::*;
use crate::fmi3::ffi::fmi3Boolean;

/// What the FMU says after an update of its discrete states (`fmi2NewDiscreteStates`,
/// `fmi3UpdateDiscreteStates`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventUpdate {
    /// Another update is needed at the same instant (the event iteration goes on).
    pub discrete_states_need_update: bool,
    pub terminate_simulation: bool,
    pub nominals_changed: bool,
    /// The continuous states changed (the integrator restarts from the new ones).
    pub states_changed: bool,
    /// The next time event, if any.
    pub next_event_time: Option<f64>,
}

/// Which function of the loaded version to call, with the names of both versions.
macro_rules! me_call {
    ($self:ident, $f:ident ( $($arg:expr),* ), $n2:literal, $n3:literal) => {{
        $self.require_me()?;
        let component = $self.component;
        let (status, name) = match &$self.fmu.inner.api {
            // SAFETY: a live component and its loaded Model Exchange function (the invariants of
            // `Instance`, and `require_me`); each pointer argument is valid for the call.
            Binary::V2(a) => (unsafe { (a.me.as_ref().expect("checked").$f)(component, $($arg),*) }, $n2),
            // SAFETY: as above, of FMI 3.0.
            Binary::V3(a) => (unsafe { (a.me.as_ref().expect("checked").$f)(component, $($arg),*) }, $n3),
        };
        $self.check(name, status)
    }};
}

impl Instance {
    fn require_me(&self) -> Result<(), Error> {
        if self.fmu.interface() == Interface::ModelExchange { Ok(()) } else { Err(self.wrong_interface()) }
    }

    /// The FMU's number of continuous states and of event indicators, as the description says.
    pub fn model_exchange_sizes(&self) -> (usize, usize) {
        let me = self.fmu.description().model_exchange.as_ref();
        me.map_or((0, 0), |m| (m.states.len(), m.event_indicators))
    }

    fn check_len(&self, what: &str, n: usize, expected: usize) -> Result<(), Error> {
        if n == expected {
            Ok(())
        } else {
            Err(Error::Usage(format!("FMU `{}`: {what}: {n} values for {expected}", self.fmu.name())))
        }
    }

    pub fn set_time(&mut self, t: f64) -> Result<(), Error> {
        me_call!(self, set_time(t), "fmi2SetTime", "fmi3SetTime")
    }

    pub fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), Error> {
        self.check_len("continuous states", x.len(), self.model_exchange_sizes().0)?;
        me_call!(self, set_continuous_states(x.as_ptr(), x.len()), "fmi2SetContinuousStates", "fmi3SetContinuousStates")
    }

    pub fn get_continuous_states(&mut self, x: &mut [f64]) -> Result<(), Error> {
        self.check_len("continuous states", x.len(), self.model_exchange_sizes().0)?;
        me_call!(
            self,
            get_continuous_states(x.as_mut_ptr(), x.len()),
            "fmi2GetContinuousStates",
            "fmi3GetContinuousStates"
        )
    }

    pub fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Error> {
        self.check_len("derivatives", dx.len(), self.model_exchange_sizes().0)?;
        me_call!(
            self,
            get_derivatives(dx.as_mut_ptr(), dx.len()),
            "fmi2GetDerivatives",
            "fmi3GetContinuousStateDerivatives"
        )
    }

    pub fn get_nominals_of_continuous_states(&mut self, x: &mut [f64]) -> Result<(), Error> {
        self.check_len("nominals", x.len(), self.model_exchange_sizes().0)?;
        me_call!(
            self,
            get_nominals_of_continuous_states(x.as_mut_ptr(), x.len()),
            "fmi2GetNominalsOfContinuousStates",
            "fmi3GetNominalsOfContinuousStates"
        )
    }

    pub fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Error> {
        self.check_len("event indicators", z.len(), self.model_exchange_sizes().1)?;
        me_call!(
            self,
            get_event_indicators(z.as_mut_ptr(), z.len()),
            "fmi2GetEventIndicators",
            "fmi3GetEventIndicators"
        )
    }

    pub fn enter_event_mode(&mut self) -> Result<(), Error> {
        me_call!(self, enter_event_mode(), "fmi2EnterEventMode", "fmi3EnterEventMode")
    }

    pub fn enter_continuous_time_mode(&mut self) -> Result<(), Error> {
        me_call!(self, enter_continuous_time_mode(), "fmi2EnterContinuousTimeMode", "fmi3EnterContinuousTimeMode")
    }

    /// The FMI 2.0 Model Exchange functions.
    fn me2(&self) -> Result<&super::api::Me, Error> {
        match &self.fmu.inner.api {
            Binary::V2(a) => a.me.as_ref().ok_or_else(|| self.wrong_interface()),
            Binary::V3(_) => Err(self.wrong_interface()),
        }
    }

    /// The FMI 3.0 Model Exchange functions.
    fn me3(&self) -> Result<&super::api3::Me3, Error> {
        match &self.fmu.inner.api {
            Binary::V3(a) => a.me.as_ref().ok_or_else(|| self.wrong_interface()),
            Binary::V2(_) => Err(self.wrong_interface()),
        }
    }

    /// `fmi2CompletedIntegratorStep` / `fmi3CompletedIntegratorStep`, `no_set_prior`: the state
    /// will not be set back before this point: (enter event mode, terminate).
    pub fn completed_integrator_step(&mut self, no_set_prior: bool) -> Result<(bool, bool), Error> {
        if self.v3.is_none() {
            let f = self.me2()?.completed_integrator_step;
            let (mut event, mut terminate) = (fmi2False, fmi2False);
            let flag = if no_set_prior { fmi2True } else { fmi2False };
            // SAFETY: a live component and its loaded function (the invariants of `Instance`);
            // the out-parameters are locals.
            let s = unsafe { f(self.component, flag, &mut event, &mut terminate) };
            self.check("fmi2CompletedIntegratorStep", s)?;
            return Ok((event != fmi2False, terminate != fmi2False));
        }
        let f = self.me3()?.completed_integrator_step;
        let (mut event, mut terminate): (fmi3Boolean, fmi3Boolean) = (0, 0);
        // SAFETY: as above, of FMI 3.0.
        let s = unsafe { f(self.component, u8::from(no_set_prior), &mut event, &mut terminate) };
        self.check("fmi3CompletedIntegratorStep", s)?;
        Ok((event != 0, terminate != 0))
    }

    /// One update of the discrete states at an event (`fmi2NewDiscreteStates`,
    /// `fmi3UpdateDiscreteStates`).
    pub fn update_discrete_states(&mut self) -> Result<EventUpdate, Error> {
        if self.v3.is_none() {
            let f = self.me2()?.new_discrete_states;
            let mut info = fmi2EventInfo::default();
            // SAFETY: a live component and its loaded function (the invariants of `Instance`);
            // the event info is a local.
            let s = unsafe { f(self.component, &mut info) };
            self.check("fmi2NewDiscreteStates", s)?;
            return Ok(EventUpdate {
                discrete_states_need_update: info.newDiscreteStatesNeeded != fmi2False,
                terminate_simulation: info.terminateSimulation != fmi2False,
                nominals_changed: info.nominalsOfContinuousStatesChanged != fmi2False,
                states_changed: info.valuesOfContinuousStatesChanged != fmi2False,
                next_event_time: (info.nextEventTimeDefined != fmi2False).then_some(info.nextEventTime),
            });
        }
        let f = self.me3()?.update_discrete_states;
        let mut b: [fmi3Boolean; 5] = [0; 5];
        let mut next = f64::NAN;
        let [a, t, n, v, d] = &mut b;
        // SAFETY: as above, of FMI 3.0; the out-parameters are locals.
        let s = unsafe { f(self.component, a, t, n, v, d, &mut next) };
        self.check("fmi3UpdateDiscreteStates", s)?;
        Ok(EventUpdate {
            discrete_states_need_update: b[0] != 0,
            terminate_simulation: b[1] != 0,
            nominals_changed: b[2] != 0,
            states_changed: b[3] != 0,
            next_event_time: (b[4] != 0).then_some(next),
        })
    }

    /// FMI 3.0: the numbers of continuous states and of event indicators the FMU reports now
    /// (they may not change: a master checks them against the description); `None` for FMI 2.0.
    pub fn reported_sizes(&mut self) -> Result<Option<(usize, usize)>, Error> {
        if self.v3.is_none() {
            return Ok(None);
        }
        let me = self.me3()?;
        let (fx, fz) = (me.get_number_of_continuous_states, me.get_number_of_event_indicators);
        let (mut nx, mut nz) = (0usize, 0usize);
        // SAFETY: a live component and its loaded functions (the invariants of `Instance`); the
        // answers go to locals.
        let s = unsafe { fx(self.component, &mut nx) };
        self.check("fmi3GetNumberOfContinuousStates", s)?;
        // SAFETY: as above.
        let s = unsafe { fz(self.component, &mut nz) };
        self.check("fmi3GetNumberOfEventIndicators", s)?;
        Ok(Some((nx, nz)))
    }
}
