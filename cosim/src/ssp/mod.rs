//! SSP 1.0 system structure descriptions: read (`.ssp` archives, `.ssd` files) and written.
