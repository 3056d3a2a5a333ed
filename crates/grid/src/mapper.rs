//! Log-odds occupancy mapping from rays at known poses.
