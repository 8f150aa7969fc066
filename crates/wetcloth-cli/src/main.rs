//! The `wetcloth` command line (placeholder until `run` lands).

fn main() {}
