//! FMI 2.0 Co-Simulation export layer (filled by the FMU work).
