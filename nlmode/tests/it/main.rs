//! nlmode's integration tests, one test binary (one link of the dependency
//! graph instead of one per file): `cargo test -p nlmode --test it [module::]`.
mod attachment;
mod dynamic;
mod frf;
mod hb;
mod matrices;
mod nma;
mod nma_nonsmooth;
mod rate;
mod reduced;
mod reference;
mod residual;
mod structure;
