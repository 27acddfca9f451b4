//! SVG figures (in progress).
