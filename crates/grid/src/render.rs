//! Rendering maps and map differences to PNG.
