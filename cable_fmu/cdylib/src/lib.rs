//! The cable_fmu model exported through the shared FMI 2.0 layer (in progress).
