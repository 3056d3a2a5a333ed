//! Map-quality metrics (paper §5.1): CC, MS and OPDF.
