//! fmu-structure's integration tests, one test binary (one link of the dependency
//! graph instead of one per file): `cargo test -p fmu-structure --test it [module::]`.
mod early_return;
mod fmi3;
mod mode_shape;
mod model;
mod model_description;
