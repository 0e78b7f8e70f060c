// Empty: a build script makes cargo resolve the [build-dependencies] below,
// which unify the features of the proc-macro side (syn) as well.
fn main() {}
