//! The zoo model `resource` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `resource`.

fmi::export_fmu!(zoo_fmus::resource::ResourceFmu);
fmi::export_fmu3!(zoo_fmus::resource::ResourceFmu);
