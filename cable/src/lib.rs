//! The cable–cabin model of the coarse-tuning system (paper eqs. 1–2): six long sagging cables,
//! each a chain of tension-only bar elements with lumped nodal masses, carrying a rigid cabin.
//!
//! * [`element`]: the tension-only bar;
//! * [`shooting`]: statics of one cable between fixed points;
//! * [`catenary`]: Irvine's elastic catenary, the analytic reference;
//! * [`net`]: the net's geometry, material and rigid bodies;
//! * [`statics`]: form finding of the unstretched lengths for a target cabin pose;
//! * [`chain_matrix`]: the chain sparsity, eliminated at linear cost onto the cabin;
//! * [`system`]: residual of the equations of motion and its exact tangent;
//! * [`eigen`]: lowest eigenpairs of a symmetric pencil (shift-invert Lanczos);
//! * [`modes`]: natural frequencies and mode shapes;
//! * [`damping`]: Rayleigh damping fitted at two frequencies;
//! * [`dynamics`]: the model in time (its side of the shared integrator, [`feedcore::genalpha`]),
//!   the sensitivity of a step to the wrench, and saving and restoring a state;
//! * [`model`]: all of the above built from a scene.

pub mod catenary;
pub mod chain_matrix;
pub mod damping;
pub mod dynamics;
pub mod eigen;
pub mod element;
pub mod model;
pub mod modes;
pub mod net;
pub mod shooting;
pub mod statics;
pub mod system;
