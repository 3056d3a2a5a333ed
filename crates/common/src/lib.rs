//! # mapkeeper-common
//!
//! The leaf every other crate may build on, and that builds on none of them: the named random
//! streams derived from one run seed ([`seeds`]), the parameter files of every component
//! ([`params`]: a preset, a TOML file laid over it key by key, one validation, and
//! [`ParamError`], what every `validate` refuses a parameter with) and the clock the
//! libraries are handed instead of reading one ([`clock`]); and, for the tests, where the
//! team's reference data lies ([`shared_data`]). A crate that needs only these (the
//! updater's tests, say) does not build the harness, the log readers or the simulator.
#![warn(missing_docs)]

pub mod clock;
pub mod params;
pub mod seeds;
pub mod shared_data;

pub use clock::{Clock, NoClock};
pub use params::{ParamError, ParamsError, load_params, params_from_toml_str};
pub use seeds::{Fnv1a64, SimRng, fnv1a64, splitmix64, stream_rng, stream_seed};
