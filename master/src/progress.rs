//! Progress bar for long runs (in progress).
