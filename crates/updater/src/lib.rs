//! mapkeeper-updater: see the crate description; under construction.
