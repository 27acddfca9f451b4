//! Cable–cabin model (in progress).
