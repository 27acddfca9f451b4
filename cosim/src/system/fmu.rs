//! A system of FMI 2.0 and 3.0 Co-Simulation FMUs: loaded, connected, parameterized and initialized from
//! a [`SystemSpec`], then stepped by the schemes through [`Units`].
//!
//! Initialization follows FMI 2.0: parameters are set after instantiation, then in
//! initialization mode the master copies every connected output to its input and repeats the
//! pass over the (algebraic) loop until nothing changes any more, and only then calls
//! fmi2ExitInitializationMode — so every FMU starts from inputs consistent with the others.

use fmi::import::{Capability, Fmu, FmuState, Instance, ScalarVariable};
use fmi::{Causality, VarType};

use super::spec::{Connection, Endpoint, Linear, Matching, Parameter, SystemSpec, Value, prefix_rest};
use super::{Capabilities, Layout, Slot, UnitError, UnitLayout, Units};
use crate::error::SetupError;
use crate::iqn::{Accelerator, IqnOptions};
use crate::me::{MeStats, MeUnit};

/// What the scheme to run needs from every FMU, checked before anything is instantiated.
#[derive(Clone, Debug, Default)]
pub struct Needs {
    /// Who needs it, for the message (e.g. `scheme iqn-ils`).
    pub what: String,
    /// Get/set FMU state.
    pub rollback: bool,
    /// How Model Exchange units are integrated.
    pub model_exchange: crate::me::MeOptions,
}

impl FmuUnit {
    /// Before a discrete input is set: event mode where the unit is of Model Exchange.
    fn begin_input_event(&mut self) -> Result<(), UnitError> {
        match self.me.as_mut() {
            Some(me) => me.begin_input_event(&mut self.inst),
            None => Ok(()),
        }
    }
}

struct FmuUnit {
    name: String,
    inst: Instance,
    /// Value references of the connected Real inputs and outputs, in layout order.
    inputs: Vec<u32>,
    outputs: Vec<u32>,
    caps: Capabilities,
    /// The FMU states of the rollback slots ([`Slot`]), allocated when first saved.
    states: [Option<FmuState>; 2],
    /// Derivative orders (all 1) for fmi2SetRealInputDerivatives.
    ones: Vec<i32>,
    /// The inputs with a nonzero seed and their seeds (a step-map derivative asks the FMU
    /// about those only: a seed per input costs one known, not all of them).
    seeded: (Vec<u32>, Vec<f64>),
    /// A Model Exchange FMU: the master's integration of it.
    me: Option<Box<MeUnit>>,
}

/// A connection of Integer, Boolean or String variables, passed at communication points.
struct DiscreteLink {
    from: (usize, u32),
    to: (usize, u32),
    var_type: VarType,
}

/// The loaded and initialized FMUs of a system.
pub struct FmuSystem {
    units: Vec<FmuUnit>,
    layout: Layout,
    discrete: Vec<DiscreteLink>,
}

// The step-map Jacobian (outputs after a step with respect to the inputs held during it) is
// not FMI 2.0's fmi2GetDirectionalDerivative (an instantaneous derivative); an FMU offers it
// through the opt-in extension `feedsimGetStepMapDerivative` (docs/fmus.md). Without it, IJCSA
// uses finite differences with rollback.
fn provides_step_map_derivative(fmu: &Fmu) -> bool {
    fmu.description().flags.provides_step_map_derivative
}

fn step_map_derivative(
    inst: &mut Instance,
    unknowns: &[u32],
    knowns: &[u32],
    seed: &[f64],
    out: &mut [f64],
) -> Result<(), fmi::import::Error> {
    inst.step_map_derivative(unknowns, knowns, seed, out)
}

fn type_name(t: VarType) -> &'static str {
    match t {
        VarType::Real => "Real",
        VarType::Integer => "Integer",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    }
}

/// One connection after name matching: output → input, with the variables.
struct Link<'a> {
    from: (usize, &'a ScalarVariable),
    to: (usize, &'a ScalarVariable),
    transform: Option<Linear>,
}

impl FmuSystem {
    /// Loads the FMUs of `spec`, checks that each offers what `needs` asks, instantiates,
    /// parameterizes, connects and initializes them at t = 0.
    pub fn load(spec: &SystemSpec, needs: &Needs) -> Result<FmuSystem, SetupError> {
        let origin = &spec.origin;
        let fmus = load_fmus(spec, needs)?;
        let index = |name: &str, what: &str| component_index(spec, name, what);
        let fmu_err = |k: usize| {
            let component = spec.components[k].name.clone();
            move |e: fmi::import::Error| SetupError::Fmu { component: component.clone(), source: e }
        };
        let links = match_links(spec, &fmus)?;

        // instances, parameters
        let mut units = Vec::with_capacity(fmus.len());
        for (k, (c, fmu)) in spec.components.iter().zip(&fmus).enumerate() {
            let mut inst = fmu.instantiate(&c.name, false).map_err(fmu_err(k))?;
            inst.setup_experiment(None, 0.0, None).map_err(fmu_err(k))?;
            let flags = &fmu.description().flags;
            let me = fmu.interface() == fmi::import::Interface::ModelExchange;
            units.push(FmuUnit {
                name: c.name.clone(),
                caps: Capabilities {
                    rollback: flags.can_get_and_set_fmu_state,
                    step_derivatives: provides_step_map_derivative(fmu) && !me,
                    // the master integrates it: it follows any input slope over the step
                    interpolates: flags.can_interpolate_inputs || me,
                },
                inst,
                inputs: Vec::new(),
                outputs: Vec::new(),
                states: [None, None],
                ones: Vec::new(),
                seeded: (Vec::new(), Vec::new()),
                me: None,
            });
        }
        for p in &spec.parameters {
            let k = index(&p.target.component, "parameter")?;
            let v = fmus[k]
                .variable(&p.target.variable)
                .map_err(|e| SetupError::Invalid(format!("{origin}: parameter `{}`: {e}", p.target)))?;
            set_value(&mut units[k].inst, v, &p.value).map_err(|e| match e {
                SetValueError::Value(m) => {
                    SetupError::Invalid(format!("{origin}: parameter `{}` = {}: {m}", p.target, p.value))
                }
                SetValueError::Fmu(e) => SetupError::Fmu { component: p.target.component.clone(), source: e },
            })?;
        }
        for (k, u) in units.iter_mut().enumerate() {
            u.inst.enter_initialization_mode().map_err(fmu_err(k))?;
        }

        // layout of U and Y: units in order, inputs and outputs in connection order
        let mut layout = Layout {
            units: Vec::new(),
            source: Vec::new(),
            gain: Vec::new(),
            offset: Vec::new(),
            scale: Vec::new(),
            group: Vec::new(),
            input_names: Vec::new(),
            output_names: Vec::new(),
            feedthrough: Vec::new(),
        };
        let real: Vec<&Link> = links.iter().filter(|l| l.from.1.var_type == VarType::Real).collect();
        for (k, unit) in units.iter_mut().enumerate() {
            let (i0, o0) = (layout.input_names.len(), layout.output_names.len());
            for l in real.iter().filter(|l| l.to.0 == k) {
                unit.inputs.push(l.to.1.value_reference);
                layout.input_names.push(format!("{}.{}", unit.name, l.to.1.name));
            }
            for l in real.iter().filter(|l| l.from.0 == k) {
                if !unit.outputs.contains(&l.from.1.value_reference) {
                    unit.outputs.push(l.from.1.value_reference);
                    layout.output_names.push(format!("{}.{}", unit.name, l.from.1.name));
                }
            }
            // outputs read besides (watched by the adaptive step): in `Y`, feeding no input
            for v in observed_outputs(&spec.observed, &unit.name, fmus[k].description()) {
                if !unit.outputs.contains(&v.value_reference) {
                    unit.outputs.push(v.value_reference);
                    layout.output_names.push(format!("{}.{}", unit.name, v.name));
                }
            }
            unit.ones = vec![1; unit.inputs.len()];
            if unit.inst.fmu().interface() == fmi::import::Interface::ModelExchange {
                unit.me = Some(Box::new(MeUnit::new(&unit.inst, &unit.inputs, needs.model_exchange)));
            }
            layout.units.push(UnitLayout {
                name: unit.name.clone(),
                inputs: i0..layout.input_names.len(),
                outputs: o0..layout.output_names.len(),
            });
        }
        for (k, unit) in units.iter().enumerate() {
            for vr in &unit.inputs {
                let l = real.iter().find(|l| l.to.0 == k && l.to.1.value_reference == *vr).expect("listed above");
                let (a, out) = (l.from.0, l.from.1.value_reference);
                let j = units[a].outputs.iter().position(|o| *o == out).expect("listed above");
                layout.source.push(layout.units[a].outputs.start + j);
                let t = l.transform.unwrap_or(Linear { factor: 1.0, offset: 0.0 });
                layout.gain.push(t.factor);
                layout.offset.push(t.offset);
            }
        }
        for (k, unit) in units.iter().enumerate() {
            let (i0, o0) = (layout.units[k].inputs.start, layout.units[k].outputs.start);
            let description = fmus[k].description();
            let real_variable =
                |vr: u32| description.variables.iter().find(|v| v.value_reference == vr && v.var_type == VarType::Real);
            for (r, &out) in unit.outputs.iter().enumerate() {
                let depends_on = real_variable(out).and_then(|v| v.depends_on.as_ref());
                for (c, &input) in unit.inputs.iter().enumerate() {
                    let name = real_variable(input).map(|v| v.name.as_str());
                    if depends_on.is_none_or(|d| name.is_some_and(|n| d.iter().any(|x| x == n))) {
                        layout.feedthrough.push((o0 + r, i0 + c));
                    }
                }
            }
        }
        let discrete = links
            .iter()
            .filter(|l| l.from.1.var_type != VarType::Real)
            .map(|l| DiscreteLink {
                from: (l.from.0, l.from.1.value_reference),
                to: (l.to.0, l.to.1.value_reference),
                var_type: l.from.1.var_type,
            })
            .collect();
        let nu = layout.inputs();
        layout.scale = vec![1.0; nu];
        let mut system = FmuSystem { units, layout, discrete };

        // consistent inputs before leaving initialization mode
        system.initialize_loop()?;
        for (k, u) in system.units.iter_mut().enumerate() {
            u.inst.exit_initialization_mode().map_err(fmu_err(k))?;
            if let Some(me) = u.me.as_mut() {
                me.start(&mut u.inst, 0.0).map_err(|e| SetupError::Fmu {
                    component: u.name.clone(),
                    source: match e {
                        UnitError::Fmi(e) => e,
                        other => fmi::import::Error::Usage(other.to_string()),
                    },
                })?;
            }
        }
        // Scales: per unit and unit of measure, the largest start value (at least 1).
        let mut u0 = vec![0.0; nu];
        for k in 0..system.units.len() {
            let r = system.layout.units[k].inputs.clone();
            system.get_inputs(k, &mut u0[r]).map_err(|e| SetupError::Fmu {
                component: system.units[k].name.clone(),
                source: match e {
                    UnitError::Fmi(e) => e,
                    other => fmi::import::Error::Usage(other.to_string()),
                },
            })?;
        }
        let keys: Vec<(usize, Option<String>)> = system
            .units
            .iter()
            .enumerate()
            .flat_map(|(k, u)| {
                u.inputs.iter().map(move |vr| {
                    let v = u
                        .inst
                        .fmu()
                        .description()
                        .variables
                        .iter()
                        .find(|v| v.value_reference == *vr && v.var_type == VarType::Real);
                    (k, v.and_then(|v| v.unit.clone()))
                })
            })
            .collect();
        system.layout.scale = Layout::group_scales(&u0, &keys);
        system.layout.group = Layout::groups(&keys);
        Ok(system)
    }

    /// Makes the connected inputs consistent with the outputs in initialization mode: the loop
    /// `U = C·Y(U)` (outputs read after inputs are set, no step in between) solved by IQN-ILS,
    /// which also converges where passing values around does not (an FMU whose outputs respond
    /// to its inputs at once closes an algebraic loop whose gain may exceed one).
    fn initialize_loop(&mut self) -> Result<(), SetupError> {
        const PASSES: usize = 200;
        let nu = self.layout.inputs();
        let mut y = vec![0.0; self.layout.outputs()];
        let (mut x, mut xt) = (vec![0.0; nu], vec![0.0; nu]);
        let err = |units: &[FmuUnit], k: usize, e: UnitError| SetupError::Fmu {
            component: units[k].name.clone(),
            source: match e {
                UnitError::Fmi(e) => e,
                other => fmi::import::Error::Usage(other.to_string()),
            },
        };
        let read_y = |s: &mut FmuSystem, y: &mut [f64]| -> Result<(), SetupError> {
            for k in 0..s.units.len() {
                let r = s.layout.units[k].outputs.clone();
                s.get_outputs(k, &mut y[r]).map_err(|e| err(&s.units, k, e))?;
            }
            Ok(())
        };
        // the first guess: the outputs as they are; scales from it
        read_y(self, &mut y)?;
        let scale: Vec<f64> = (0..nu).map(|i| self.layout.coupled(i, &y).abs().max(1.0)).collect();
        for i in 0..nu {
            x[i] = self.layout.coupled(i, &y) / scale[i];
        }
        let mut iqn = Accelerator::new(nu, IqnOptions { reuse: 0, filter: 1e-10, initial_relaxation: 1.0 });
        iqn.start_window();
        for _ in 0..PASSES {
            for k in 0..self.units.len() {
                let r = self.layout.units[k].inputs.clone();
                let u: Vec<f64> = r.clone().map(|i| x[i] * scale[i]).collect();
                self.set_inputs(k, &u).map_err(|e| err(&self.units, k, e))?;
            }
            let discrete_changed = self.exchange(true).map_err(|(k, e)| err(&self.units, k, e))?;
            read_y(self, &mut y)?;
            let mut worst = (0.0, 0);
            for i in 0..nu {
                xt[i] = self.layout.coupled(i, &y) / scale[i];
                let change = (xt[i] - x[i]).abs();
                if !(change <= worst.0) {
                    worst = (change, i);
                }
            }
            if worst.0 <= 1e-13 && !discrete_changed {
                return Ok(());
            }
            if worst.0 > 1e12 {
                return Err(SetupError::Initialization {
                    iterations: PASSES,
                    variable: self.layout.input_names[worst.1].clone(),
                    change: worst.0,
                });
            }
            iqn.update(&mut x, &xt);
        }
        let worst = (0..nu).map(|i| ((xt[i] - x[i]).abs(), i)).fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
        Err(SetupError::Initialization {
            iterations: PASSES,
            variable: self.layout.input_names.get(worst.1).cloned().unwrap_or_default(),
            change: worst.0,
        })
    }

    /// Copies every non-Real connection; with `compare`, returns whether any input changed. A
    /// Model Exchange unit takes a changed value in event mode (an input event, FMI 2.0 and 3.0:
    /// discrete inputs are not set in continuous-time mode), and an unchanged one not at all.
    fn exchange(&mut self, compare: bool) -> Result<bool, (usize, UnitError)> {
        let mut changed = false;
        for l in &self.discrete {
            let (a, b) = (l.from.0, l.to.0);
            let e = |k: usize| move |e: fmi::import::Error| (k, UnitError::Fmi(e));
            // a Model Exchange unit's input is read to set it only if it changes
            let me = self.units[b].me.is_some();
            let look = compare || me;
            let differs = match l.var_type {
                VarType::Integer => {
                    let (mut x, mut old) = ([0], [0]);
                    self.units[a].inst.get_integer(&[l.from.1], &mut x).map_err(e(a))?;
                    if look {
                        self.units[b].inst.get_integer(&[l.to.1], &mut old).map_err(e(b))?;
                    }
                    let differs = look && x != old;
                    if differs || !me {
                        self.units[b].begin_input_event().map_err(|e| (b, e))?;
                        self.units[b].inst.set_integer(&[l.to.1], &x).map_err(e(b))?;
                    }
                    differs
                }
                VarType::Boolean => {
                    let (mut x, mut old) = ([false], [false]);
                    self.units[a].inst.get_boolean(&[l.from.1], &mut x).map_err(e(a))?;
                    if look {
                        self.units[b].inst.get_boolean(&[l.to.1], &mut old).map_err(e(b))?;
                    }
                    let differs = look && x != old;
                    if differs || !me {
                        self.units[b].begin_input_event().map_err(|e| (b, e))?;
                        self.units[b].inst.set_boolean(&[l.to.1], &x).map_err(e(b))?;
                    }
                    differs
                }
                VarType::String => {
                    let x = self.units[a].inst.get_string(&[l.from.1]).map_err(e(a))?;
                    let differs = look && self.units[b].inst.get_string(&[l.to.1]).map_err(e(b))? != x;
                    if differs || !me {
                        self.units[b].begin_input_event().map_err(|e| (b, e))?;
                        self.units[b].inst.set_string(&[l.to.1], &[x[0].as_str()]).map_err(e(b))?;
                    }
                    differs
                }
                VarType::Real => unreachable!("Real connections are interface unknowns"),
            };
            changed |= compare && differs;
        }
        for (k, unit) in self.units.iter_mut().enumerate() {
            if let Some(me) = unit.me.as_mut() {
                me.end_input_event(&mut unit.inst).map_err(|e| (k, e))?;
            }
        }
        Ok(changed)
    }

    fn get_inputs(&mut self, k: usize, u: &mut [f64]) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        Ok(unit.inst.get_real(&unit.inputs, u)?)
    }

    /// The FMU instance of component `name`, to read or set any of its variables.
    pub fn instance(&mut self, name: &str) -> Option<&mut Instance> {
        self.units.iter_mut().find(|u| u.name == name).map(|u| &mut u.inst)
    }

    /// The components' names and instances, in the order of the description.
    pub fn instances(&mut self) -> impl Iterator<Item = (&str, &mut Instance)> {
        self.units.iter_mut().map(|u| (u.name.as_str(), &mut u.inst))
    }

    /// What the integration of each Model Exchange unit did so far: (component, solver, stats).
    pub fn model_exchange_stats(&self) -> Vec<(String, &'static str, MeStats)> {
        let me = |u: &FmuUnit| u.me.as_ref().map(|m| (u.name.clone(), m.method_name(), m.stats));
        self.units.iter().filter_map(me).collect()
    }

    /// Serialized states of every FMU (for checks of bit-exact rollback).
    pub fn serialized_states(&mut self) -> Result<Vec<Vec<u8>>, fmi::import::Error> {
        let mut out = Vec::new();
        for u in &mut self.units {
            let s = u.inst.get_state()?;
            out.push(u.inst.serialize_state(&s)?);
            u.inst.free_state(s)?;
        }
        Ok(out)
    }

    /// fmi2Terminate on every FMU (at the end of a run).
    pub fn terminate(&mut self) -> Result<(), SetupError> {
        for u in &mut self.units {
            u.inst.terminate().map_err(|e| SetupError::Fmu { component: u.name.clone(), source: e })?;
        }
        Ok(())
    }
}

/// The Real outputs of component `component` that `observed` names (`component.variable`, or a
/// prefix of it ending before a `.` or `[`).
fn observed_outputs<'a>(
    observed: &'a [String],
    component: &'a str,
    description: &'a fmi::ModelDescription,
) -> impl Iterator<Item = &'a ScalarVariable> + 'a {
    description.variables.iter().filter(move |v| {
        v.var_type == VarType::Real
            && v.causality == Causality::Output
            && observed.iter().any(|name| {
                name.strip_prefix(component)
                    .and_then(|rest| rest.strip_prefix('.'))
                    .is_some_and(|variable| prefix_rest(&v.name, variable).is_some())
            })
    })
}

/// Loads every component's FMU, checking what `needs` asks of it.
fn load_fmus(spec: &SystemSpec, needs: &Needs) -> Result<Vec<Fmu>, SetupError> {
    let origin = &spec.origin;
    let mut fmus = Vec::with_capacity(spec.components.len());
    for c in &spec.components {
        let path = &c.source;
        let fmu = if path.is_dir() {
            Fmu::load_unpacked_as(path, c.interface)
        } else if path.is_file() {
            Fmu::load_as(path, c.interface)
        } else {
            return Err(SetupError::File {
                path: path.clone(),
                message: format!(
                    "FMU of component `{}` ({origin}) not found (the FMUs of this workspace are built by \
                     `cargo build --release --workspace && target/release/master package --out dist`)",
                    c.name
                ),
            });
        };
        let fmu = fmu.map_err(|e| SetupError::Fmu { component: c.name.clone(), source: e })?;
        if needs.rollback && fmu.require(Capability::GetSetState).is_err() {
            return Err(SetupError::Capability {
                what: needs.what.clone(),
                capability: "rollback (get/set FMU state)",
                component: c.name.clone(),
                fmu: fmu.name().to_owned(),
                attribute: Capability::GetSetState.attribute(),
            });
        }
        fmus.push(fmu);
    }
    Ok(fmus)
}

fn component_index(spec: &SystemSpec, name: &str, what: &str) -> Result<usize, SetupError> {
    spec.components.iter().position(|c| c.name == name).ok_or_else(|| {
        let names: Vec<&str> = spec.components.iter().map(|c| c.name.as_str()).collect();
        SetupError::Invalid(format!("{}: {what}: no component named `{name}` (components: {names:?})", spec.origin))
    })
}

/// Every connection of `spec` resolved to one output and one input, checked (causality, type,
/// units, declared connectors, inputs connected once).
fn match_links<'a>(spec: &SystemSpec, fmus: &'a [Fmu]) -> Result<Vec<Link<'a>>, SetupError> {
    let origin = &spec.origin;
    let index = |name: &str, what: &str| component_index(spec, name, what);
    // every link, by name
    let mut links: Vec<Link> = Vec::new();
    for c in &spec.connections {
        let what = format!("connection {} → {}", c.from, c.to);
        let (a, b) = (index(&c.from.component, &what)?, index(&c.to.component, &what)?);
        let before = links.len();
        match c.matching {
            Matching::Exact => {
                let v = fmus[a]
                    .variable(&c.from.variable)
                    .map_err(|e| SetupError::Invalid(format!("{origin}: {what}: {e}")))?;
                let t = fmus[b]
                    .variable(&c.to.variable)
                    .map_err(|e| SetupError::Invalid(format!("{origin}: {what}: {e}")))?;
                links.push(Link { from: (a, v), to: (b, t), transform: c.transform });
            }
            Matching::Prefix => {
                for v in &fmus[a].description().variables {
                    let Some(suffix) = prefix_rest(&v.name, &c.from.variable) else {
                        continue;
                    };
                    if v.causality != Causality::Output {
                        continue;
                    }
                    let target = format!("{}{suffix}", c.to.variable);
                    let t = fmus[b].variable(&target).map_err(|_| {
                        SetupError::Invalid(format!(
                            "{origin}: {what}: `{}` has no input `{target}` for output `{}`",
                            c.to.component, v.name
                        ))
                    })?;
                    links.push(Link { from: (a, v), to: (b, t), transform: c.transform });
                }
                if links.len() == before {
                    return Err(SetupError::Invalid(format!(
                        "{origin}: {what}: `{}` has no output named `{}…`",
                        c.from.component, c.from.variable
                    )));
                }
            }
        }
        for l in &links[before..] {
            check_link(origin, &spec.components[l.from.0].name, &spec.components[l.to.0].name, l, c)?;
        }
    }
    for (i, l) in links.iter().enumerate() {
        // value references are unique per type only
        if links[..i].iter().any(|m| {
            m.to.0 == l.to.0 && m.to.1.value_reference == l.to.1.value_reference && m.to.1.var_type == l.to.1.var_type
        }) {
            return Err(SetupError::Invalid(format!(
                "{origin}: input `{}.{}` is connected twice; an input takes one output",
                spec.components[l.to.0].name, l.to.1.name
            )));
        }
    }
    for d in &spec.connectors {
        let k = index(&d.endpoint.component, "connector")?;
        let v = fmus[k]
            .variable(&d.endpoint.variable)
            .map_err(|e| SetupError::Invalid(format!("{origin}: connector `{}`: {e}", d.endpoint)))?;
        if v.var_type != d.var_type {
            return Err(SetupError::Invalid(format!(
                "{origin}: connector `{}` is declared {} but the FMU's variable is {}",
                d.endpoint,
                type_name(d.var_type),
                type_name(v.var_type)
            )));
        }
        if let (Some(declared), Some(actual)) = (&d.unit, &v.unit)
            && declared != actual
        {
            return Err(SetupError::Invalid(format!(
                "{origin}: connector `{}` declares unit `{declared}` but the FMU's variable has `{actual}`",
                d.endpoint
            )));
        }
    }

    Ok(links)
}

/// A connection of one output to one input, as the FMUs resolve it.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedConnection {
    pub from: Endpoint,
    pub to: Endpoint,
    pub var_type: VarType,
    pub from_unit: Option<String>,
    pub to_unit: Option<String>,
    pub transform: Option<Linear>,
}

/// A system description resolved against its FMUs (loaded, not instantiated): connections one
/// output to one input, parameter values typed as the variables they set.
pub struct Resolved {
    pub fmus: Vec<Fmu>,
    pub connections: Vec<ResolvedConnection>,
    pub parameters: Vec<(Parameter, VarType, Option<String>)>,
}

/// Resolves `spec` against its FMUs, checking it as [`FmuSystem::load`] does.
pub fn resolve(spec: &SystemSpec) -> Result<Resolved, SetupError> {
    let fmus = load_fmus(spec, &Needs::default())?;
    let links = match_links(spec, &fmus)?;
    let name = |k: usize| spec.components[k].name.clone();
    let connections = links
        .iter()
        .map(|l| ResolvedConnection {
            from: Endpoint { component: name(l.from.0), variable: l.from.1.name.clone() },
            to: Endpoint { component: name(l.to.0), variable: l.to.1.name.clone() },
            var_type: l.from.1.var_type,
            from_unit: l.from.1.unit.clone(),
            to_unit: l.to.1.unit.clone(),
            transform: l.transform,
        })
        .collect();
    let mut parameters = Vec::new();
    for p in &spec.parameters {
        let k = component_index(spec, &p.target.component, "parameter")?;
        let v = fmus[k]
            .variable(&p.target.variable)
            .map_err(|e| SetupError::Invalid(format!("{}: parameter `{}`: {e}", spec.origin, p.target)))?;
        let bad =
            |m: String| SetupError::Invalid(format!("{}: parameter `{}` = {}: {m}", spec.origin, p.target, p.value));
        let value = match &p.value {
            Value::Text(x) => Value::Typed(typed(x, v.var_type).map_err(bad)?),
            typed => typed.clone(),
        };
        parameters.push((Parameter { target: p.target.clone(), value }, v.var_type, v.unit.clone()));
    }
    Ok(Resolved { fmus, connections, parameters })
}

/// Checks one link: causalities, types, units.
fn check_link(origin: &str, from: &str, to: &str, l: &Link, c: &Connection) -> Result<(), SetupError> {
    let (v, t) = (l.from.1, l.to.1);
    let at = format!("{origin}: connection `{from}.{}` → `{to}.{}`", v.name, t.name);
    if v.causality != Causality::Output {
        return Err(SetupError::Invalid(format!("{at}: `{from}.{}` is not an output", v.name)));
    }
    if t.causality != Causality::Input {
        return Err(SetupError::Invalid(format!("{at}: `{to}.{}` is not an input", t.name)));
    }
    if v.var_type != t.var_type {
        return Err(SetupError::Invalid(format!(
            "{at}: a {} output cannot feed a {} input",
            type_name(v.var_type),
            type_name(t.var_type)
        )));
    }
    if c.transform.is_some() && v.var_type != VarType::Real {
        return Err(SetupError::Invalid(format!("{at}: a linear transformation needs Real variables")));
    }
    if let (Some(a), Some(b)) = (&v.unit, &t.unit)
        && a != b
        && c.transform.is_none()
    {
        return Err(SetupError::Invalid(format!(
            "{at}: the units differ (`{a}` → `{b}`); connect variables of one unit, or give the \
             connection a linear transformation (SSP ssc:LinearTransformation) that converts them"
        )));
    }
    Ok(())
}

enum SetValueError {
    Value(String),
    Fmu(fmi::import::Error),
}

fn set_value(inst: &mut Instance, v: &ScalarVariable, value: &Value) -> Result<(), SetValueError> {
    let vr = [v.value_reference];
    let mismatch = || SetValueError::Value(format!("the variable is {}", type_name(v.var_type)));
    let parsed;
    let value = match value {
        Value::Typed(x) => x,
        Value::Text(x) => {
            parsed = typed(x, v.var_type).map_err(SetValueError::Value)?;
            &parsed
        }
    };
    let r = match (v.var_type, value) {
        (VarType::Real, fmi::Value::Real(x)) => inst.set_real(&vr, &[*x]),
        (VarType::Real, fmi::Value::Integer(x)) => inst.set_real(&vr, &[f64::from(*x)]),
        (VarType::Integer, fmi::Value::Integer(x)) => inst.set_integer(&vr, &[*x]),
        (VarType::Boolean, fmi::Value::Boolean(x)) => inst.set_boolean(&vr, &[*x]),
        (VarType::String, fmi::Value::String(x)) => inst.set_string(&vr, &[x.as_str()]),
        _ => return Err(mismatch()),
    };
    r.map_err(SetValueError::Fmu)
}

/// A parameter's text as a value of the variable's type.
fn typed(text: &str, var_type: VarType) -> Result<fmi::Value, String> {
    let bad = |e: &dyn std::fmt::Display| format!("not {}: {e}", article(var_type));
    Ok(match var_type {
        VarType::Real => fmi::Value::Real(text.trim().parse().map_err(|e| bad(&e))?),
        VarType::Integer => fmi::Value::Integer(text.trim().parse().map_err(|e| bad(&e))?),
        VarType::Boolean => fmi::Value::Boolean(text.trim().parse().map_err(|e| bad(&e))?),
        VarType::String => fmi::Value::String(text.to_owned()),
    })
}

/// "a Real", "an Integer", ...
fn article(t: VarType) -> String {
    let name = type_name(t);
    if name.starts_with(['A', 'E', 'I', 'O', 'U']) { format!("an {name}") } else { format!("a {name}") }
}

/// The FMU's end ends the run (FMI 2.0: fmi2Discard from doStep; FMI 3.0: terminateSimulation
/// or an early return); anything else is a failure.
fn step_error(inst: &mut Instance, e: fmi::import::Error) -> UnitError {
    if let fmi::import::Error::Ended { time, terminated, .. } = e {
        let signal = if terminated { "fmi3DoStep: terminateSimulation" } else { "fmi3DoStep: earlyReturn" };
        return UnitError::Ended { last_successful_time: Some(time).filter(|t| t.is_finite()), terminated, signal };
    }
    if e.status() == Some(fmi::ffi::Status::Discard) {
        let terminated = inst.terminated().unwrap_or(false);
        let last_successful_time = inst.last_successful_time().ok().filter(|t| t.is_finite());
        let signal = if terminated { "fmi2Discard, fmi2Terminated" } else { "fmi2Discard" };
        return UnitError::Ended { last_successful_time, terminated, signal };
    }
    UnitError::Fmi(e)
}

impl Units for FmuSystem {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn capabilities(&self, k: usize) -> Capabilities {
        self.units[k].caps
    }

    fn set_inputs(&mut self, k: usize, u: &[f64]) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        if let Some(me) = unit.me.as_mut() {
            return me.set_inputs(&mut unit.inst, u);
        }
        Ok(unit.inst.set_real(&unit.inputs, u)?)
    }

    fn set_input_slopes(&mut self, k: usize, slopes: &[f64]) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        if let Some(me) = unit.me.as_mut() {
            me.slopes_set(slopes);
            return Ok(());
        }
        Ok(unit.inst.set_real_input_derivatives(&unit.inputs, &unit.ones, slopes)?)
    }

    fn do_step(&mut self, k: usize, t: f64, h: f64) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        if let Some(me) = unit.me.as_mut() {
            return me.advance(&mut unit.inst, t, h);
        }
        unit.inst.do_step(t, h).map_err(|e| step_error(&mut unit.inst, e))
    }

    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        Ok(unit.inst.get_real(&unit.outputs, y)?)
    }

    fn save_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        let state = &mut unit.states[slot as usize];
        match state {
            Some(s) => unit.inst.update_state(s)?,
            None => *state = Some(unit.inst.get_state()?),
        }
        if let Some(me) = unit.me.as_mut() {
            me.save(slot as usize);
        }
        Ok(())
    }

    fn restore_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        let s = unit.states[slot as usize]
            .as_ref()
            .ok_or_else(|| UnitError::Other(format!("no state saved in the {slot:?} slot to restore")))?;
        unit.inst.set_state(s)?;
        if let Some(me) = unit.me.as_mut() {
            me.restore(slot as usize);
        }
        Ok(())
    }

    fn step_derivative(&mut self, k: usize, seed: &[f64], out: &mut [f64]) -> Result<(), UnitError> {
        let unit = &mut self.units[k];
        let (knowns, seeds) = &mut unit.seeded;
        knowns.clear();
        seeds.clear();
        for (&vr, &s) in unit.inputs.iter().zip(seed) {
            if s != 0.0 {
                knowns.push(vr);
                seeds.push(s);
            }
        }
        Ok(step_map_derivative(&mut unit.inst, &unit.outputs, knowns, seeds, out)?)
    }

    fn exchange_discrete(&mut self) -> Result<(), (usize, UnitError)> {
        self.exchange(false).map(|_| ())
    }
}
