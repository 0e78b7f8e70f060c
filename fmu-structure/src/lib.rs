//! # structure — the nonlinear-mode oscillator as an FMI 2.0 CS and ME FMU
//!
//! The time-domain nonlinear-mode oscillator of DESIGN.md section 4
//! ([`nlmode::oscillator`]) driven by the force of an attachment at one point
//! of the modal table.
//!
//! Physics in [`nlmode::oscillator`]; [`model`] only maps the FMI variables
//! onto it. See `README.md` for the equations and the variable table;
//! `modelDescription/structure/` holds the modelDescription.xml rendered
//! from [`model::VARIABLES`] and [`model::INFO`].
//!
//! * input `F` [N]: force on the structure at the drive point, positive along
//!   positive displacement; over a step it is `F + F' s + F'' s^2/2` with the
//!   derivatives from `fmi2SetRealInputDerivatives` (zero unless given, reset
//!   after every step);
//! * outputs `x`, `v` (drive point), `x_tip`, `a`, `omega`, none with direct
//!   feedthrough from `F`;
//! * parameters `frequency_error` (`omega -> (1 + eps) omega`), `drive_point`
//!   (name in the table, default `2l3`), `drive_point_index` (index into the
//!   table's points, used when >= 0), `modal_table` (path; empty: the
//!   `modal_table.json` of the FMU's `resources/` folder).
pub mod model;

pub use model::{vr, Structure, DEFAULT_DRIVE_POINT, RESOURCE_TABLE, TIP_POINT};

fmi2_export::export_fmu!(model::Structure);
fmi2_export::export_fmu3!(model::Structure);
