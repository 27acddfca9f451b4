//! The zoo model `resource` exported as the FMI 2.0 Co-Simulation FMU `resource`.

fmi2::export_fmu!(zoo_fmus::resource::ResourceFmu);
