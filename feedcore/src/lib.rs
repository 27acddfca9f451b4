//! Shared pieces of the feed-positioning models.
//!
//! * [`scene`]: the scene file (TOML) both models and the master read, with validation;
//! * [`files`]: reading a file the user points at, within a limit;
//! * [`rigid`]: rotations on SO(3) and rigid-body mass properties;
//! * [`stewart_geometry`]: where the Stewart platform's joints and masses sit on the cabin;
//! * [`genalpha`]: the generalized-α integrator with its Newton controller, used by every model;
//! * [`wind`]: the wind load on the cabin (mean plus seeded Kaimal turbulence).

pub mod benchkit;
pub mod files;
pub mod genalpha;
pub mod random;
pub mod rigid;
pub mod scene;
pub mod shipped;
pub mod stewart_geometry;
pub mod wind;

pub use nalgebra;

/// Vectors and matrices of the models: small, fixed-size, `f64`.
pub type Vec3 = nalgebra::Vector3<f64>;
pub type Mat3 = nalgebra::Matrix3<f64>;
pub type Quat = nalgebra::UnitQuaternion<f64>;
