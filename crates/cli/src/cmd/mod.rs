//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod localise;
pub mod map;
pub mod metrics;
pub mod render;
pub mod simulate;
pub mod update;
pub mod validate;
