//! World generation: the seeded evolution W_1 … W_N of a warehouse by edits to movable items
//! in its storage areas ([`generator`], with the item outlines of [`outline`]), and the initial
//! map M_1 built from an exploration run ([`mapping`]).

pub mod generator;
pub mod mapping;
pub mod observed;
pub mod outline;
pub mod site;

/// What can go wrong while generating worlds or building M_1.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorldsError {
    /// A parameter is out of range (checked once, where a run starts).
    #[error("parameter {} is invalid: {}", .0.name, .0.problem())]
    InvalidParam(#[from] mapkeeper_common::ParamError),
    /// The simulator refused a world or its parameters.
    #[error(transparent)]
    Sim(#[from] mapkeeper_sim::SimError),
    /// The mapper refused its parameters.
    #[error("mapper: {0}")]
    Mapper(#[from] mapkeeper_grid::mapper::MapperError),
    /// The exploration run failed.
    #[error("exploration run: {0}")]
    Loop(#[from] mapkeeper_harness::HarnessError),
    /// The generator could not make a valid world.
    #[error("scenario generator: {0}")]
    Generator(String),
}
