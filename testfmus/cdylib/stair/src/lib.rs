//! The zoo model `stair` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `stair`.

fmi::export_fmu!(zoo_fmus::stair::StairFmu);
fmi::export_fmu3!(zoo_fmus::stair::StairFmu);
