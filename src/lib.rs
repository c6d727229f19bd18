//! sgplvm: teach a family of robots the same motions from one set of human demonstrations.
pub use sgplvm_core as core;
pub use sgplvm_robots as robots;
