//! mapkeeper-localiser: see the crate description; under construction.
