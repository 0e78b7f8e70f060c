//! Keeps modelDescription.xml and the code from drifting apart: parse the XML
//! with the one schema ([`fmi2::schema`]), list what
//! [`ModelDescription::validate`] finds, and compare every `<ScalarVariable>`
//! with the model's [`Variable`] table, the GUID and `modelIdentifier`.
pub use fmi2::schema::ModelDescription;

use crate::model::{CoSimModel, Start, VarType, Variable};

fn start_matches(s: &Start, xml: &str) -> bool {
    match s {
        Start::Real(x) => xml.trim().parse::<f64>().map(|y| y == *x).unwrap_or(false),
        Start::Integer(i) => xml.trim().parse::<i32>().map(|y| y == *i).unwrap_or(false),
        Start::Boolean(b) => matches!(
            (xml.trim(), b),
            ("true", true) | ("false", false) | ("1", true) | ("0", false)
        ),
        Start::String(t) => xml == *t,
    }
}

/// Compare the XML with the code's identity and variable table; every
/// mismatch and every [`ModelDescription::validate`] problem is reported
/// (`Ok` = agreement). The validation includes that
/// `<ModelStructure><Outputs>` lists exactly the output variables, in order.
pub fn check_model_description(
    xml: &str,
    model_identifier: &str,
    guid: &str,
    variables: &[Variable],
) -> Result<ModelDescription, Vec<String>> {
    let md = ModelDescription::parse(xml).map_err(|e| vec![e.to_string()])?;
    let mut errs: Vec<String> = md.validate().iter().map(|p| p.to_string()).collect();
    if md.guid != guid {
        errs.push(format!("guid {:?} in XML, {:?} in code", md.guid, guid));
    }
    let id = &md.co_simulation.model_identifier;
    if id != model_identifier {
        errs.push(format!(
            "modelIdentifier {id:?} in XML, {model_identifier:?} in code"
        ));
    }
    if let Some(me) = &md.model_exchange {
        // one binary provides both interfaces
        if me.model_identifier != model_identifier {
            errs.push(format!(
                "<ModelExchange> modelIdentifier {:?} in XML, {model_identifier:?} in code",
                me.model_identifier
            ));
        }
    }
    if md.variables.len() != variables.len() {
        errs.push(format!(
            "{} variables in XML, {} in code",
            md.variables.len(),
            variables.len()
        ));
    }
    for v in variables {
        let Some(x) = md.variables.iter().find(|x| x.name == v.name) else {
            errs.push(format!("variable {} missing in XML", v.name));
            continue;
        };
        if x.value_reference != v.vr {
            errs.push(format!(
                "{}: valueReference {} in XML, {} in code",
                v.name, x.value_reference, v.vr
            ));
        }
        for (what, differs, xml, code) in [
            ("type", x.ty != v.ty, x.ty.name(), format!("{:?}", v.ty)),
            (
                "causality",
                x.causality != v.causality,
                x.causality.name(),
                format!("{:?}", v.causality),
            ),
            (
                "variability",
                x.variability != v.variability,
                x.variability.name(),
                format!("{:?}", v.variability),
            ),
        ] {
            if differs {
                errs.push(format!("{}: {what} {xml} in XML, {code} in code", v.name));
            }
        }
        match (&v.start, &x.start) {
            (None, None) => {}
            (Some(s), Some(xs)) if start_matches(s, xs) => {}
            (s, xs) => errs.push(format!(
                "{}: start {:?} in XML, {:?} in code",
                v.name, xs, s
            )),
        }
        let unit = x.unit.as_deref().unwrap_or("");
        if unit != v.unit {
            errs.push(format!(
                "{}: unit {:?} in XML, {:?} in code",
                v.name, unit, v.unit
            ));
        }
        if x.description.is_empty() {
            errs.push(format!("{}: no description in XML", v.name));
        }
    }
    for x in &md.variables {
        if !variables.iter().any(|v| v.name == x.name) {
            errs.push(format!(
                "variable {} of the XML is unknown to the code",
                x.name
            ));
        }
    }
    if errs.is_empty() {
        Ok(md)
    } else {
        Err(errs)
    }
}

/// Check the Model Exchange part of the XML against the model's
/// [`CoSimModel::CONTINUOUS_STATES`]: `<ModelExchange>` present iff the model
/// has continuous states, `numberOfEventIndicators = 0` (event-free), each
/// derivative variable's `derivative` attribute naming its state, and
/// `<Derivatives>` listing the derivatives in the table's order. (Their
/// `dependencies` are checked by [`check_dependencies`].)
pub fn check_model_exchange<M: CoSimModel>(md: &ModelDescription) -> Vec<String> {
    let mut errs = Vec::new();
    let states = M::CONTINUOUS_STATES;
    match (&md.model_exchange, states.is_empty()) {
        (Some(_), true) => {
            errs.push("<ModelExchange> in XML, but the model has no continuous states".into())
        }
        (None, false) => errs.push(format!(
            "the model has {} continuous states but the XML has no <ModelExchange>",
            states.len()
        )),
        _ => {}
    }
    if md.number_of_event_indicators != 0 {
        errs.push(format!(
            "numberOfEventIndicators = {} in XML, the model is event-free (0)",
            md.number_of_event_indicators
        ));
    }
    let index_of = |vr: u32| {
        md.variables
            .iter()
            .find(|v| v.value_reference == vr && v.ty == fmi2::schema::VarType::Real)
            .map(|v| v.index)
    };
    if md.derivatives.len() != states.len() {
        errs.push(format!(
            "<Derivatives> lists {} unknowns, the model has {} continuous states",
            md.derivatives.len(),
            states.len()
        ));
    }
    for (k, s) in states.iter().enumerate() {
        let (Some(si), Some(di)) = (index_of(s.state_vr), index_of(s.derivative_vr)) else {
            errs.push(format!(
                "continuous state {k}: Real value reference {} or {} missing in XML",
                s.state_vr, s.derivative_vr
            ));
            continue;
        };
        let d = &md.variables[di - 1];
        if d.derivative != Some(si) {
            errs.push(format!(
                "{}: derivative={:?} in XML, the code makes it the derivative of index {si}",
                d.name, d.derivative
            ));
        }
        if md.derivatives.get(k).map(|u| u.index) != Some(di) {
            errs.push(format!(
                "<Derivatives> entry {} should be index {di} ({})",
                k + 1,
                d.name
            ));
        }
    }
    errs
}

/// Check that a freshly instantiated model reports the XML/table start values
/// of its Real variables (masters that never set start values rely on it).
pub fn check_start_values<M: CoSimModel>(model: &M) -> Vec<String> {
    M::VARIABLES
        .iter()
        .filter_map(|v| match v.start {
            Some(Start::Real(s)) if v.ty == VarType::Real => {
                let got = model.get_real(v.vr);
                (got != s).then(|| format!("{}: start {s} declared, model has {got}", v.name))
            }
            Some(Start::Boolean(b)) => match model.get_boolean(v.vr) {
                Ok(got) if got == b => None,
                other => Some(format!(
                    "{}: start {b} declared, model has {other:?}",
                    v.name
                )),
            },
            Some(Start::Integer(i)) => match model.get_integer(v.vr) {
                Ok(got) if got == i => None,
                other => Some(format!(
                    "{}: start {i} declared, model has {other:?}",
                    v.name
                )),
            },
            _ => None,
        })
        .collect()
}

/// Perturb a known (`Real` or `Boolean`) of a model; `None` for the types the
/// check does not perturb (String, Integer: listing them is not verified).
fn perturb<M: CoSimModel>(m: &mut M, v: &fmi2::schema::ScalarVariable) -> Option<()> {
    match v.ty {
        fmi2::schema::VarType::Real => {
            let x = m.get_real(v.value_reference);
            // small enough to keep every parameter in its valid range
            let y = if x == 0.0 { 1e-3 } else { x * (1.0 + 1e-3) };
            m.set_real(v.value_reference, y).ok()
        }
        fmi2::schema::VarType::Boolean => {
            let b = m.get_boolean(v.value_reference).ok()?;
            m.set_boolean(v.value_reference, !b).ok()
        }
        _ => None,
    }
}

/// Check `<ModelStructure>` against the code's actual dependencies
/// (the algebraic-loop information a master relies on, FMI 2.0 section 2.2.8):
///
/// * `<Outputs>`: an output lists input `j` iff setting `j` (without a step)
///   changes the output's `fmi2GetReal` (direct feedthrough);
/// * `<Derivatives>` (Model Exchange): a state derivative lists every input
///   and continuous state whose perturbation changes it (from all states at
///   their nominal values; extra, structural entries are accepted);
/// * `<InitialUnknowns>`: an unknown lists input or parameter `j` iff setting
///   `j` before `fmi2ExitInitializationMode` changes its value after it; every
///   initial unknown must carry a `dependencies` attribute (absent means
///   "depends on everything", which masters read as an algebraic loop).
///
/// `instantiate(k)` returns a fresh instance in configuration `k` of
/// `configurations` (parameters set, not yet initialized); a dependency counts
/// as present when it shows in any configuration (e.g. `u_ext` only acts with
/// `use_external_voltage = true`). Real knowns are perturbed by 0.1 % (or
/// 1e-3 from zero), Booleans toggled; String and Integer knowns are not
/// perturbed, so listing them is accepted unchecked. Returns the disagreements.
pub fn check_dependencies<M: CoSimModel>(
    md: &ModelDescription,
    configurations: usize,
    instantiate: impl Fn(usize) -> M,
) -> Vec<String> {
    let c = DependencyCheck {
        md,
        configurations,
        instantiate,
        log: crate::model::Logger::silent(),
        inputs: md
            .variables
            .iter()
            .filter(|v| v.causality == "input")
            .collect(),
    };
    let mut errs = Vec::new();
    // each part stops the check (`Err(Stop)`) where the model cannot be
    // initialized or set; its messages are in `errs`
    let _ = c
        .outputs(&mut errs)
        .and_then(|_| c.derivatives(&mut errs))
        .and_then(|_| c.initial_unknowns(&mut errs));
    errs
}

/// The check of [`check_dependencies`] stops here (the reason is in its messages).
struct Stop;

/// What the parts of [`check_dependencies`] share.
struct DependencyCheck<'a, F> {
    md: &'a ModelDescription,
    configurations: usize,
    instantiate: F,
    log: crate::model::Logger,
    inputs: Vec<&'a fmi2::schema::ScalarVariable>,
}

impl<'a, M: CoSimModel, F: Fn(usize) -> M> DependencyCheck<'a, F> {
    fn initialize(&self, mut m: M, errs: &mut Vec<String>) -> Result<M, Stop> {
        let r = m
            .setup_experiment(0.0, None)
            .and_then(|_| m.enter_initialization_mode(&self.log))
            .and_then(|_| m.exit_initialization_mode(&self.log));
        match r {
            Ok(()) => Ok(m),
            Err(e) => {
                errs.push(format!("initialization failed: {e}"));
                Err(Stop)
            }
        }
    }

    fn read(&self, m: &M, i: usize) -> Option<f64> {
        let v = self.md.variables.iter().find(|v| v.index == i)?;
        match v.ty {
            fmi2::schema::VarType::Real => Some(m.get_real(v.value_reference)),
            _ => None,
        }
    }

    /// `<Outputs>`: direct feedthrough from the inputs in the initialized state.
    fn outputs(&self, errs: &mut Vec<String>) -> Result<(), Stop> {
        for u in &self.md.outputs {
            let listed = u.dependencies.clone().unwrap_or_default();
            for inp in &self.inputs {
                let mut changes = false;
                for k in 0..self.configurations {
                    let base = self.initialize((self.instantiate)(k), errs)?;
                    let mut m = base.clone();
                    if perturb(&mut m, inp).is_none() {
                        continue;
                    }
                    changes |= self.read(&base, u.index) != self.read(&m, u.index);
                }
                if changes != listed.contains(&inp.index) {
                    errs.push(format!(
                        "<Outputs> index {}: direct dependency on input {} (index {}) is {} in the code, {} in the XML",
                        u.index,
                        inp.name,
                        inp.index,
                        if changes { "present" } else { "absent" },
                        if listed.contains(&inp.index) { "listed" } else { "not listed" }
                    ));
                }
            }
        }
        Ok(())
    }

    /// `<Derivatives>`: from the initialized model with every continuous state
    /// at its nominal value, a derivative must list each input and state whose
    /// perturbation changes it (listing more is allowed: the dependencies are
    /// structural, e.g. `omega(a)` makes a rate depend on a state even where a
    /// linear table hides it); get_real of each derivative variable must equal
    /// `derivatives`.
    fn derivatives(&self, errs: &mut Vec<String>) -> Result<(), Stop> {
        let md = self.md;
        let states: Vec<usize> = M::CONTINUOUS_STATES
            .iter()
            .filter_map(|s| {
                md.variables
                    .iter()
                    .find(|v| {
                        v.value_reference == s.state_vr && v.ty == fmi2::schema::VarType::Real
                    })
                    .map(|v| v.index)
            })
            .collect();
        let nominal: Vec<f64> = M::CONTINUOUS_STATES.iter().map(|s| s.nominal).collect();
        let mut me_bases = Vec::new();
        if !md.derivatives.is_empty() {
            for k in 0..self.configurations {
                let mut m = self.initialize((self.instantiate)(k), errs)?;
                if let Err(e) = m.set_continuous_states(&nominal) {
                    errs.push(format!("set_continuous_states({nominal:?}) failed: {e}"));
                    return Err(Stop);
                }
                let mut dx = vec![0.0; nominal.len()];
                match m.derivatives(&mut dx) {
                    Ok(()) => {
                        for (s, d) in M::CONTINUOUS_STATES.iter().zip(&dx) {
                            let g = m.get_real(s.derivative_vr);
                            if g != *d {
                                errs.push(format!(
                                    "get_real({}) = {g} but derivatives() gives {d}",
                                    s.derivative_vr
                                ));
                            }
                        }
                    }
                    Err(e) => errs.push(format!("derivatives failed: {e}")),
                }
                me_bases.push(m);
            }
        }
        for u in &md.derivatives {
            let listed = u.dependencies.clone().unwrap_or_default();
            let mut present: Vec<(usize, String)> = Vec::new();
            for base in &me_bases {
                for inp in &self.inputs {
                    let mut m = base.clone();
                    if perturb(&mut m, inp).is_some()
                        && self.read(base, u.index) != self.read(&m, u.index)
                    {
                        present.push((inp.index, inp.name.clone()));
                    }
                }
                for (j, &si) in states.iter().enumerate() {
                    let mut x = nominal.clone();
                    x[j] *= 1.0 + 1e-3;
                    let mut m = base.clone();
                    if let Err(e) = m.set_continuous_states(&x) {
                        errs.push(format!("set_continuous_states failed: {e}"));
                        return Err(Stop);
                    }
                    if self.read(base, u.index) != self.read(&m, u.index) {
                        present.push((si, md.variables[si - 1].name.clone()));
                    }
                }
            }
            present.sort();
            present.dedup();
            for (i, name) in present {
                if !listed.contains(&i) {
                    errs.push(format!(
                        "<Derivatives> index {}: depends on {name} (index {i}) in the code, not listed in the XML",
                        u.index
                    ));
                }
            }
        }
        Ok(())
    }

    /// `<InitialUnknowns>`: values after initialization vs inputs and
    /// parameters set before it.
    fn initial_unknowns(&self, errs: &mut Vec<String>) -> Result<(), Stop> {
        let md = self.md;
        let knowns: Vec<_> = md
            .variables
            .iter()
            .filter(|v| v.causality == "input" || v.causality == "parameter")
            .collect();
        let bases: Vec<M> = (0..self.configurations)
            .filter_map(|k| self.initialize((self.instantiate)(k), errs).ok())
            .collect();
        if bases.len() != self.configurations {
            return Err(Stop);
        }
        for u in &md.initial_unknowns {
            let Some(listed) = u.dependencies.clone() else {
                errs.push(format!(
                    "<InitialUnknowns> index {} (line {}) has no dependencies attribute (= depends on all knowns)",
                    u.index, u.line
                ));
                continue;
            };
            for kn in &knowns {
                let mut changes = false;
                let mut checked = false;
                for (k, base) in bases.iter().enumerate() {
                    let mut m = (self.instantiate)(k);
                    if perturb(&mut m, kn).is_none() {
                        continue;
                    }
                    checked = true;
                    let m = self.initialize(m, errs)?;
                    changes |= self.read(base, u.index) != self.read(&m, u.index);
                }
                if checked && changes != listed.contains(&kn.index) {
                    errs.push(format!(
                        "<InitialUnknowns> index {}: dependency on {} (index {}) is {} in the code, {} in the XML",
                        u.index,
                        kn.name,
                        kn.index,
                        if changes { "present" } else { "absent" },
                        if listed.contains(&kn.index) { "listed" } else { "not listed" }
                    ));
                }
            }
        }
        Ok(())
    }
}
