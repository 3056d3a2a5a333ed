//! mapkeeper-scenario: see the crate description; under construction.
