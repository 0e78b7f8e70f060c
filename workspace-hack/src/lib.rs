//! Feature unification for the workspace (the "workspace-hack" pattern of
//! cargo-hakari, written by hand): every member depends on this crate, which
//! enables on shared dependencies the union of the features that any member
//! or dev-dependency enables. `cargo test -p nlmode`, `cargo build --workspace`
//! and maturin's build of `python/` then resolve the same features and reuse
//! each other's compiled units instead of rebuilding half the graph.
//! No code. Regenerate the lists with `tests/unify_features.py`.
