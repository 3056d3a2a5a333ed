//! The experiments, each on the closed loop of `mapkeeper-closed-loop` (its runner, controls,
//! pose oracle, setup and trial runner). At the top, what the experiments' reports share: the
//! scores ([`scores`]) and a recorded log with a localiser's error against its reference poses
//! ([`reference`](mod@reference)). Then one module per experiment, each with its parameters, its
//! run and its report, none importing another: the hundred-world validation ([`validation`],
//! with its structure retention and change-class scores, [`validation::erosion`], the
//! sensor-realism sweep of its chain, and the merge, comparison and check of its results), the
//! recovery suite ([`recovery`]), check detection ([`check_detection`]), Table 1 with a held pose
//! ([`table1_hold`]), kidnaps of the robot ([`kidnap_robot`]), real logs ([`real_data`]), real
//! scans against a known truth ([`real_scans`]) and the localisers' convergence from a start
//! error ([`convergence`]).

pub mod check_detection;
pub mod convergence;
pub mod kidnap_robot;
pub mod real_data;
pub mod real_scans;
pub mod recovery;
pub mod reference;
pub mod scores;
pub mod table1_hold;
pub mod validation;

pub use mapkeeper_closed_loop::ExperimentError;
pub(crate) use mapkeeper_closed_loop::{check_route, check_turn};
