//! The Stewart platform model exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `stewart_fmu`.

fmi::export_fmu!(stewart_fmu::StewartFmu);
fmi::export_fmu3!(stewart_fmu::StewartFmu);
