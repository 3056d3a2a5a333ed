//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod generate;
pub mod localise;
pub mod map;
pub mod merge;
pub mod metrics;
pub mod recover;
pub mod render;
pub mod run;
pub mod simulate;
pub mod update;
pub mod validate;
