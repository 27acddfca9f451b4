//! The test model `hostile_me` exported as the FMI 2.0 and FMI 3.0 Model Exchange FMU `hostile_me`.

fmi::export_fmu!(zoo_fmus::hostile::HostileFmu);
fmi::export_fmu3!(zoo_fmus::hostile::HostileFmu);
