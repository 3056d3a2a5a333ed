//! mapkeeper-sim: see the crate description; under construction.
