//! The structure FMU (filled by the FMU work).
