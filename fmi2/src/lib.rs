//! FMI 2.0 Co-Simulation support (in progress).
