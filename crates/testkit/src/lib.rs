//! # mapkeeper-testkit
//!
//! Test support shared by the crates' tests, used only as a dev-dependency (`publish = false`):
//!
//! - [`rooms`]: the small hand-made maps the tests build (walled rooms, furniture set by cell
//!   or by metre), one copy each instead of one per test file;
//! - [`corpus`]: the walk over the kept fuzz corpus (`fuzz/corpus/<target>/`, see
//!   `docs/reliability.md`) that each crate's `tests/fuzz_corpus.rs` feeds to its parsers: the
//!   folder found, its files listed in order, a failing file named;
//! - [`import_graph`]: every crate's files and which file names an item of which, the graph
//!   behind `tests/import_circles.rs` (no two files of a crate import each other, directly or
//!   round a longer circle; issue 56).
//!
//! It depends on the grid crate only, so it stays in the dev trees of the estimators without
//! bringing the simulator, the physics engine, the harness or the log readers with it
//! (`.ci/check-deps`). The grid crate's own integration tests use it too (a dev-dependency
//! cycle Cargo allows); the grid's `src` unit tests cannot take a map from it, because there
//! the grid types are the unit-test build's own, not the ones this crate was built against.
#![warn(missing_docs)]

pub mod corpus;
pub mod import_graph;
pub mod rooms;
