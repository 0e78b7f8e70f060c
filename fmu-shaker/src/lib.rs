//! The shaker FMU (filled by the FMU work).
