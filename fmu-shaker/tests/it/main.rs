//! fmu-shaker's integration tests, one test binary (one link of the dependency
//! graph instead of one per file): `cargo test -p fmu-shaker --test it [module::]`.
mod cosim_damping;
mod fmi3;
mod model_description;
mod physics;
