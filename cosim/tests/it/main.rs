//! cosim's integration tests, one test binary (one link of the dependency
//! graph instead of one per file): `cargo test -p cosim --test it [module::]`.
mod bounded_inputs;
