//! Stewart platform model (in progress).
