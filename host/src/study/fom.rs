//! The figures of merit of a sample: [`crate::figures`], the one definition
//! `summary.json` uses too.
pub use crate::figures::{Figures, Fold};
