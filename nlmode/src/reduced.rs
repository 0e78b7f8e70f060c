//! The single nonlinear modal oscillator with linear attachments (`eq:NM`),
//! paper Section 3: slow flow, steady state, linear variants, imposed force,
//! post-processing. (filled in by the reduced-model work)
