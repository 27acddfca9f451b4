//! The cable–cabin model exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `cable_fmu`.

fmi::export_fmu!(cable_fmu::CableFmu);
fmi::export_fmu3!(cable_fmu::CableFmu);
