//! The test model `hostile_me` exported as the FMI 2.0 and FMI 3.0 Model Exchange FMU `hostile_me`.

fmi2::export_fmu!(zoo_fmus::hostile::HostileFmu);
fmi2::export_fmu3!(zoo_fmus::hostile::HostileFmu);
