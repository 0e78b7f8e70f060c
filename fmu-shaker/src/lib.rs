//! # shaker — the electrodynamic exciter of the paper's Section 4 as an FMI 2.0 CS and ME FMU
//!
//! States `s = [I, q_a, v_a]`, inputs: structure drive-point displacement `x`
//! and velocity `v`, external voltage `u_ext`; the applied voltage `u` comes
//! from the internal linear sine sweep or from `u_ext`:
//!
//! ```text
//! L I'   = u - R I - G v_a
//! m_a v_a' = G I - d_a v_a - k_a q_a - k_s (q_a - x),   q_a' = v_a
//! F      = k_s (q_a - x)      (stinger force on the structure, + along + x)
//! ```
//!
//! (`nlmode::attachment::ShakerParams::state_space`, stepped by
//! `nlmode::attachment::ShakerStepper`). The system is LTI, so
//! each step is integrated exactly ([`nlmode::lti`]) with inputs linear in
//! time: `x` is extrapolated inside the step from `x`, `v` (or the input
//! derivatives the master gives), which removes most of the apparent damping
//! a zero-order hold of the stiff stinger coupling would add. The internal
//! sweep voltage is followed with sub-steps of at most
//! [`model::MAX_PHASE_PER_SUBSTEP`] rad of excitation phase.
//!
//! See `README.md` for the variable table; `modelDescription/shaker/`
//! holds the modelDescription.xml rendered from [`model::VARIABLES`] and
//! [`model::INFO`].
pub mod model;

pub use model::Shaker;

fmi2_export::export_fmu!(model::Shaker);
fmi2_export::export_fmu3!(model::Shaker);
