//! `gfsvo`: the command users type.
fn main() {}
