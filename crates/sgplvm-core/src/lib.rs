//! Shared GP-LVM core (placeholder until the model lands).
