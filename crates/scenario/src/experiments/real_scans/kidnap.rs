//! (issue 52, item 4: being written)
