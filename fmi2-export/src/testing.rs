//! Checks an FMU crate's tests run on its model (the same in every FMU
//! crate, `tests/it/model_description.rs`):
//!
//! * [`check_model_description_file`]: the checked-in
//!   `modelDescription/<id>/modelDescription.xml` is the one rendered from
//!   the code, byte for byte (rewritten with [`UPDATE_ENV`]`=1`), and agrees
//!   with the variable table by [`crate::xml`]'s checks;
//! * [`check_capabilities`]: the model backs what its
//!   [`Capabilities`](crate::description::Capabilities) declare.
use std::path::Path;

use crate::description::Layout;
use crate::model::{Causality, CoSimModel, Logger, StateReader, StateWriter, VarType, Variability};
use crate::xml::{check_model_description, check_model_exchange, ModelDescription};

/// Set to `1` to (re)write the checked-in modelDescription.xml from the code.
pub const UPDATE_ENV: &str = "UPDATE_MODEL_DESCRIPTION";

/// Compare the file at `path` with the modelDescription rendered from `M`
/// ([`crate::render::model_description`]); with `UPDATE_MODEL_DESCRIPTION=1`
/// write it instead. The rendered text must also pass
/// [`check_model_description`] and [`check_model_exchange`]. Returns the
/// parsed description, or every problem with how to regenerate the file.
pub fn check_model_description_file<M: CoSimModel>(
    path: &Path,
) -> Result<ModelDescription, String> {
    let xml = crate::render::model_description::<M>().map_err(|e| e.to_string())?;
    let md = check_model_description(&xml, M::MODEL_IDENTIFIER, M::GUID, M::VARIABLES)
        .map_err(|e| format!("the rendered modelDescription is wrong:\n{}", e.join("\n")))?;
    let errs = check_model_exchange::<M>(&md);
    if !errs.is_empty() {
        return Err(format!(
            "the rendered modelDescription is wrong:\n{}",
            errs.join("\n")
        ));
    }
    compare_or_update(path, &xml)?;
    Ok(md)
}

/// The FMI 3.0 counterpart of [`check_model_description_file`]: the file at
/// `path` (`modelDescription/<id>_fmi3/modelDescription.xml`) is the one
/// [`crate::render3::model_description`] renders from `M` (written instead
/// with `UPDATE_MODEL_DESCRIPTION=1`). Returns the rendered text.
pub fn check_model_description_file3<M: CoSimModel>(path: &Path) -> Result<String, String> {
    let xml = crate::render3::model_description::<M>().map_err(|e| e.to_string())?;
    compare_or_update(path, &xml)?;
    Ok(xml)
}

/// Write `xml` to `path` with `UPDATE_MODEL_DESCRIPTION=1`, else compare.
fn compare_or_update(path: &Path, xml: &str) -> Result<(), String> {
    if std::env::var(UPDATE_ENV).is_ok_and(|v| v == "1") {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        std::fs::write(path, xml).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        return Ok(());
    }
    let on_disk = std::fs::read_to_string(path).unwrap_or_default();
    if on_disk == xml {
        return Ok(());
    }
    let line = on_disk
        .lines()
        .zip(xml.lines())
        .position(|(a, b)| a != b)
        .unwrap_or(on_disk.lines().count().min(xml.lines().count()));
    let show = |s: &str| s.lines().nth(line).unwrap_or("(end of file)").to_string();
    let package = std::env::var("CARGO_PKG_NAME").unwrap_or_else(|_| "<the FMU crate>".into());
    let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    Err(format!(
        "{} is not the modelDescription the code gives; first difference at line {}:\n  \
         file: {}\n  code: {}\nRegenerate it with `{UPDATE_ENV}=1 cargo test -p {package} --test it \
         model_description` and commit it.",
        path.display(),
        line + 1,
        show(&on_disk),
        show(xml),
    ))
}

fn serialize<M: CoSimModel>(m: &M) -> Vec<u8> {
    let mut w = StateWriter::new();
    m.serialize_state(&mut w);
    w.into_bytes()
}

/// Every Real, Integer and Boolean value of a model (NaN compared bitwise).
fn snapshot<M: CoSimModel>(m: &M) -> Vec<String> {
    M::VARIABLES
        .iter()
        .map(|v| match v.ty {
            VarType::Real => format!("{} = {:?}", v.name, m.get_real(v.vr).to_bits()),
            VarType::Integer => format!("{} = {:?}", v.name, m.get_integer(v.vr).ok()),
            VarType::Boolean => format!("{} = {:?}", v.name, m.get_boolean(v.vr).ok()),
            _ => format!("{} = {:?}", v.name, m.get_string(v.vr).ok()),
        })
        .collect()
}

/// Check that `model` (initialized, i.e. after
/// `fmi2ExitInitializationMode`) backs the capabilities `M::INFO` declares,
/// with steps of `h` seconds:
///
/// * FMU state (every model): the state after a step, serialized and
///   restored into the state before it, gives the same values of every
///   variable;
/// * `canHandleVariableCommunicationStepSize`: steps of `h` then `h / 2`;
/// * `canInterpolateInputs`: a first-order derivative of every continuous
///   Real input is accepted;
/// * `maxOutputDerivativeOrder`: every continuous Real output has finite
///   derivatives up to that order;
/// * `providesDirectionalDerivative`: every continuous Real output (and
///   state derivative) has a finite partial derivative with respect to every
///   continuous Real input (and state), zero where `<ModelStructure>` lists
///   no dependency.
///
/// Returns the disagreements.
pub fn check_capabilities<M: CoSimModel>(model: &M, h: f64) -> Vec<String> {
    let caps = M::INFO.capabilities;
    let log = Logger::silent();
    let mut errs = Vec::new();
    let real = |c: Causality| {
        M::VARIABLES
            .iter()
            .filter(move |v| {
                v.ty == VarType::Real
                    && v.causality == c
                    && v.variability == Variability::Continuous
            })
            .collect::<Vec<_>>()
    };
    let (inputs, outputs) = (real(Causality::Input), real(Causality::Output));
    // FMU state round trip over a step
    let before = model.clone();
    let mut after = model.clone();
    match after.do_step(0.0, h, &log) {
        Err(e) => errs.push(format!("do_step(0, {h}) failed: {e}")),
        Ok(()) => {
            let bytes = serialize(&after);
            let mut restored = before.clone();
            let r = restored.deserialize_state(&mut StateReader::new(&bytes));
            if let Err(e) = r {
                errs.push(format!(
                    "deserialize_state of a serialized state failed: {e}"
                ));
            } else if snapshot(&restored) != snapshot(&after) {
                errs.push("a restored FMU state gives other values than the saved one".into());
            } else if serialize(&restored) != bytes {
                errs.push("a restored FMU state serializes differently".into());
            }
            if caps.can_handle_variable_communication_step_size {
                if let Err(e) = after.do_step(h, h / 2.0, &log) {
                    errs.push(format!(
                        "canHandleVariableCommunicationStepSize: a step of {h}, then of {}: {e}",
                        h / 2.0
                    ));
                }
            }
        }
    }
    if caps.can_interpolate_inputs {
        for v in &inputs {
            if let Err(e) = model.clone().set_real_input_derivative(v.vr, 1, 0.0) {
                errs.push(format!("canInterpolateInputs: input {}: {e}", v.name));
            }
        }
    }
    for order in 1..=caps.max_output_derivative_order {
        for v in &outputs {
            match model.get_real_output_derivative(v.vr, order) {
                Ok(d) if d.is_finite() => {}
                r => errs.push(format!(
                    "maxOutputDerivativeOrder: derivative of order {order} of {}: {r:?}",
                    v.name
                )),
            }
        }
    }
    if caps.provides_directional_derivative {
        errs.extend(directional_derivatives::<M>(model, &inputs, &outputs));
    }
    errs
}

/// The `providesDirectionalDerivative` part of [`check_capabilities`].
fn directional_derivatives<M: CoSimModel>(
    model: &M,
    inputs: &[&crate::model::Variable],
    outputs: &[&crate::model::Variable],
) -> Vec<String> {
    let mut errs = Vec::new();
    let layout = match Layout::of::<M>() {
        Ok(l) => l,
        Err(e) => return vec![e.to_string()],
    };
    let position = |vr: u32| {
        M::VARIABLES
            .iter()
            .position(|v| v.vr == vr && v.ty == VarType::Real)
    };
    let states: Vec<u32> = M::CONTINUOUS_STATES.iter().map(|s| s.state_vr).collect();
    let ders: Vec<u32> = M::CONTINUOUS_STATES
        .iter()
        .map(|s| s.derivative_vr)
        .collect();
    let knowns: Vec<u32> = inputs.iter().map(|v| v.vr).chain(states).collect();
    let mut pairs: Vec<(u32, u32, bool)> = Vec::new();
    for o in outputs {
        for i in inputs {
            pairs.push((o.vr, i.vr, true));
        }
    }
    for &d in &ders {
        for &k in &knowns {
            pairs.push((d, k, false));
        }
    }
    for (unknown, known, output) in pairs {
        let name = |vr: u32| position(vr).map_or("?", |i| M::VARIABLES[i].name);
        match model.partial_derivative(unknown, known) {
            Ok(d) if d.is_finite() => {
                let list = if output {
                    &layout.outputs
                } else {
                    &layout.derivatives
                };
                let listed = list.iter().any(|u| {
                    Some(u.variable) == position(unknown)
                        && position(known).is_some_and(|k| u.dependencies.contains(&k))
                });
                if d != 0.0 && !listed {
                    errs.push(format!(
                        "providesDirectionalDerivative: d{}/d{} = {d} but <{}> lists no such dependency",
                        name(unknown),
                        name(known),
                        if output { "Outputs" } else { "Derivatives" }
                    ));
                }
            }
            r => errs.push(format!(
                "providesDirectionalDerivative: d{}/d{}: {r:?}",
                name(unknown),
                name(known)
            )),
        }
    }
    errs
}

/// SplitMix64: the fixed, dependency-free pseudo-random sequence of the
/// seeded fuzz-style tests (FMI layers, importer, scenarios).
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// An index in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}
