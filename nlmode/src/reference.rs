//! Primal assembly of structure and attachments (`eq:finalassembly1`-
//! `eq:finalassembly2`) and full-order time integration over a sweep.
//! (filled in by the reference work)
